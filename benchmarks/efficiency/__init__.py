"""The efficiency study (Homel & Herbold 2017, section 3.5): :mod:`benchmarks.efficiency.measure`; the driver ``study.py``."""
