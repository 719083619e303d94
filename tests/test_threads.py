"""Threads: the waiting policy pfmpm sets for OpenMP (src/pfmpm/__init__.py),
a short spin unless the user chose one, and the solver's choice of each
step's thread count, which must not change a bit of the result. Their effect
on speed is measured in docs/performance/threads.md, not here."""

import os
import subprocess
import sys

import pytest

SCRIPT = """
import os
import pfmpm
print(os.environ.get("GOMP_SPINCOUNT"), os.environ.get("OMP_WAIT_POLICY"))
"""


def environment_after_import(**env):
    base = {k: v for k, v in os.environ.items() if k not in ("GOMP_SPINCOUNT", "OMP_WAIT_POLICY")}
    r = subprocess.run([sys.executable, "-c", SCRIPT], env={**base, **env}, capture_output=True,
                       text=True, check=True)
    return r.stdout.split()


def test_a_short_spin_unless_the_user_chose_a_policy():
    import pfmpm

    assert environment_after_import() == [str(pfmpm.SPIN_COUNT), "None"]
    assert environment_after_import(OMP_WAIT_POLICY="active") == ["None", "active"]
    assert environment_after_import(GOMP_SPINCOUNT="5") == ["5", "None"]


def borden_coarse(partition: str | None):
    """The Borden plate at h = 1 mm, l0 = 2 mm, one particle per cell (4,000
    particles), its fields one or split by the phase field's damage."""
    from pathlib import Path

    from pfmpm.scene import Scene

    demo = Path(__file__).resolve().parents[1] / "demos" / "borden_plate.toml"
    return Scene.from_toml(demo, ["grid.h=1.0", "materials.concrete.fracture.l0=2.0",
                                  "bodies.plate.particles_per_cell=1", "time.end=20"]
                           + ([f"contact.partition={partition}"] if partition else []))


def state_bytes(sim) -> bytes:
    p = sim.particles
    return p.x.tobytes() + p.v.tobytes() + p.stress.tobytes() + p.c.tobytes()


@pytest.mark.parametrize("partition", [None, "damage_gradient"])
def test_changing_the_thread_count_between_steps_keeps_the_bits(partition):
    """The premise of the solver's thread governor (ThreadGovernor), which
    picks each step's count from the steps' times: 40 steps on 1, 2, 1, 2, ...
    threads (the notch's history makes every phase-field solve nontrivial)
    have the bits of 40 steps on 2 threads. The governor leaves the count as
    it was on return."""
    from pfmpm import _core
    from pfmpm.simulation import Simulation

    before = _core.num_threads()
    try:
        fixed, switched = Simulation(borden_coarse(partition)), Simulation(borden_coarse(partition))
        for sim in (fixed, switched):
            sim.solver.adaptive_threads = False
        _core.set_num_threads(2)
        fixed.advance(40)
        for k in range(40):
            _core.set_num_threads(1 + k % 2)
            switched.advance(1)
        assert state_bytes(switched) == state_bytes(fixed)
        assert fixed.solver.reduced_thread_steps == 0

        adaptive = Simulation(borden_coarse(partition))
        assert adaptive.solver.adaptive_threads
        _core.set_num_threads(2)
        adaptive.advance(40)
        assert _core.num_threads() == 2
        assert state_bytes(adaptive) == state_bytes(fixed)
    finally:
        _core.set_num_threads(before)


def test_the_governor_is_switched_off_by_the_environment(monkeypatch):
    from pfmpm.scene import SceneError
    from pfmpm.simulation import adaptive_threads

    monkeypatch.delenv("PFMPM_ADAPTIVE_THREADS", raising=False)
    assert adaptive_threads()
    monkeypatch.setenv("PFMPM_ADAPTIVE_THREADS", "0")
    assert not adaptive_threads()
    monkeypatch.setenv("PFMPM_ADAPTIVE_THREADS", "no")
    with pytest.raises(SceneError, match=r"^PFMPM_ADAPTIVE_THREADS = 'no': must be 0 or 1$"):
        adaptive_threads()
