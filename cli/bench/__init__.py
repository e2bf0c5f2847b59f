"""The benchmarks behind ``viscore bench``: figures printed, never asserted.

They live beside the library, not in it, and call its public names through the
packages' faces (as scikit-image's ``benchmarks/``): they need the whole chain
(core, metrics and the generators), and only the command line sits above all
three. A benchmark imports the faces, :mod:`viscore.cli._common` and the
modules of this folder, never a subcommand's module.

- :mod:`.command`: the ``bench`` parser and the text of each figure.
- :mod:`.core`: ``bench rays``, ``bench voxels``, ``bench evaluate``.
- :mod:`.aabb_skins`: ``bench generate aabb-skins``, beside the C++ peer.
- :mod:`.planar`: ``bench generate planar-sections`` and its ablations.
- :mod:`.table1`, :mod:`.scale`: Table 1 of the planar-sections paper, and the
  cost of planar sections against the triangle count.
- :mod:`.hybrid`: ``bench generate hybrid`` and its ablation (Wu et al. Fig. 11).
- :mod:`.surface_patches`, :mod:`.terrain_drape`: ``bench generate
  surface-patches`` and ``terrain-drape``.
- :mod:`.cull`: ``bench cull``.
- :mod:`.cull_runtimes`: per-frame culling runtimes on a procedural city
  (``python -m viscore.cli.bench.cull_runtimes``).
- :mod:`.godot_bake`: ``bench godot-bake``, our ``godot`` baseline against
  Godot's own bake of its occlusion demo.
- :mod:`.models`: the ``--models`` folder of extra meshes.
- :mod:`._plot`: the one plotting helper of the benchmarks.
"""
