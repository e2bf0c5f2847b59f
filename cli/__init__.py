"""The ``viscore`` command line: one entry point, thin over the library.

Every subcommand module does three things: parse its options, call one public
function of the library (``viscore``, ``viscore.metrics``,
``viscore.generators``), format the result (text, or one JSON document with
``--json``). It does no numerics and imports no private names of the library
but its shared validators (``viscore._validate``) and atomic writers
(``viscore._atomic``); memory estimates come from
:mod:`viscore.metrics.estimates`, mesh files from :func:`viscore.exchange.mesh_io.save_mesh`.

Subcommands, and the module each lives in:

- ``viscore generate METHOD MESH -o OUT``: :mod:`.generate_cmd`
- ``viscore measure | evaluate | validate``: :mod:`.metrics_cmd`
- ``viscore uncertainty`` (and ``uncertainty ablation``): :mod:`.uncertainty_cmd`
- ``viscore compare [MESH ...]``: :mod:`.compare_cmd`, running the study of
  :mod:`.study`
- ``viscore cull [SCENE]``: :mod:`.cull_cmd`
- ``viscore data list | export``: :mod:`.data_cmd`
- ``viscore bench rays|voxels|evaluate|generate|cull``: :mod:`.bench.command`

:mod:`.main` builds the parser from these modules and holds the one error
rule (exit codes 0, 1, 2, 3, 130); :mod:`._common` the output helpers (JSON,
atomic files, output paths).

Subpackages:

- :mod:`.study`: the study runner of ``compare``: ``store`` (the SQLite
  store, the locked study folder), ``runner`` (jobs, the local process pool,
  dask), ``tables`` (Markdown/CSV tables, paired rows), ``report``
  (``report.html`` and the ``.glb`` per occluder).
- :mod:`.bench`: the benchmarks, one module per benchmark, and the ``bench``
  command's parser.
"""
