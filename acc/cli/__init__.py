"""The ``acc`` command line: ``run``, ``analyze``, ``tune``, ``sweep``, ``check``."""
