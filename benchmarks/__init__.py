"""The paper problems, one folder each: a ``benchmark.toml``, the drivers that
run and measure the problem, and where a problem has measures of its own, its
``measure`` module (``benchmarks.kalthoff_winkler.measure``, ...).

:mod:`pfmpm.post` keeps the measures that read any run; what only one problem
asks lives here. ``benchmarks.common`` holds what several problems share.
The drivers are run as files from the repository root
(``.venv/bin/python benchmarks/<name>/<driver>.py``) and put the root on
``sys.path`` themselves; the tests import the package from the root
(``pythonpath`` in ``pyproject.toml``).
"""
