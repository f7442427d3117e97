"""The command line: ``homecog home``, ``homecog train`` and the rest."""
