"""The waiting policy pfmpm sets for OpenMP (src/pfmpm/__init__.py): a short
spin unless the user chose one. Its effect on speed is measured in
docs/performance.md, not here."""

import os
import subprocess
import sys

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
