"""Report pages of ``compare``, ``cull`` and ``occlude``: one look, pictures by ray casting."""
