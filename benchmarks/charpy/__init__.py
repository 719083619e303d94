"""The modified Charpy impact (Homel & Herbold 2017, section 3.3): :mod:`benchmarks.charpy.measure`; the drivers ``study.py`` and ``diagnose.py``."""
