"""The ``viscore`` command line: one entry point, thin over the library.

Every subcommand module does three things: parse its options, call one public
function of the library, format the result (text, or one JSON document with
``--json``). It does no numerics and imports the library only through its
packages' faces (``viscore``, ``viscore.exchange``, ``viscore.level``,
``viscore.culling``, ``viscore.metrics``, ``viscore.generators``,
``viscore.generators.levels``, ...: the names on their ``__all__``), besides
the core's shared helpers: validators (``viscore._validate``), atomic writers
and locked output folders (``viscore._atomic``) and the job runner
(``viscore._jobs``). A subcommand module imports no other subcommand's module
nor a benchmark: only :mod:`._common` and its own subpackage (``compare``: the
study runner). Memory estimates come from :func:`viscore.metrics.study_bytes`
and its kind, mesh files from :func:`viscore.exchange.save_mesh`.

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
