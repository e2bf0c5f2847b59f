"""The benchmarks behind ``viscore bench``: figures printed, never asserted.

They live beside the library, not in it, and call its public names (as
scikit-image's ``benchmarks/``): they need the whole chain (core, metrics and
the generators), and only the command line sits above all three.

- :mod:`.command`: the ``bench`` parser and the text of each figure.
- :mod:`.core`: ``bench rays``, ``bench voxels``, ``bench evaluate``.
- :mod:`.aabb_skins`: ``bench generate aabb-skins``, beside the C++ peer.
- :mod:`.planar`: ``bench generate planar-sections`` and its ablations.
- :mod:`.hybrid`: ``bench generate hybrid`` and its ablation (Wu et al. Fig. 11).
- :mod:`.cull`: ``bench cull``, and the culling column of ``viscore compare``.
- :mod:`.walks`: ``bench walks LEVEL...``: where each level's walk stands, and (``--cull``)
  the truth's hidden share beside the best guaranteed culled share.
- :mod:`.cull_runtimes`: per-frame culling runtimes on a procedural city
  (``python -m viscore.cli.bench.cull_runtimes``).
- :mod:`.models`: the ``--models`` folder of extra meshes.
- :mod:`._plot`: the one plotting helper of the benchmarks.
"""
