"""A viscore plugin package, for the tests (``tests/plugin_fixture``)."""
