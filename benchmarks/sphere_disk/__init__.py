"""A steel sphere fragmenting a thick alumina disk (Homel & Herbold 2017, section 4, Fig. 20): :mod:`benchmarks.sphere_disk.measure`; the driver ``study.py``."""
