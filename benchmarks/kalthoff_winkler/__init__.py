"""Kalthoff-Winkler (Homel & Herbold 2017, section 3.2): :mod:`benchmarks.kalthoff_winkler.measure`; the driver ``compare.py``."""
