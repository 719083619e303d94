"""The disk hitting a beam (Kakouris & Triantafyllou 2019, section 5.3): :mod:`benchmarks.disk_beam.measure`; the drivers ``running_crack.py`` and ``cone_sweep.py``."""
