"""The dynamic Brazilian disk (Homel & Herbold 2017, section 3.4): :mod:`benchmarks.brazilian.measure`; the drivers ``study.py`` and ``time_step.py``."""
