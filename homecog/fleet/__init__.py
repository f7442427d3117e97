"""A fleet of homes: many homes in one database, learned as tasks on Ray
(:mod:`homecog.fleet.train`) and served by stateless servers (:mod:`homecog.fleet.serve`)."""
