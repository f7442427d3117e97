"""The HTTP API, one module per resource.

Routes whose bodies depend on the home (the context and what carries it) are made per home by
``router(models)``; their modules do without ``from __future__ import annotations``, because
FastAPI reads the annotations at run time and the home's models are local to ``router``.
"""
