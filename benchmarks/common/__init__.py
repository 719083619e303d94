"""What several benchmarks share: the self-contact variants and the single-field
scene of the impact problems (:mod:`benchmarks.common.self_contact`) and the
results file each driver writes (:mod:`benchmarks.common.results`)."""
