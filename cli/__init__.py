"""The ``viscore`` command line: one entry point, thin over the library."""
