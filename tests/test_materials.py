"""The materials registry of pfmpm.scene: a scene's ``model`` key picks the
class that declares and checks the table, and a new model is one registered
class."""

from dataclasses import dataclass
from typing import ClassVar

import pytest

import pfmpm.scene
from pfmpm.scene import (MATERIALS, FractureSpec, GridSpec, LinearElasticSpec, MaterialSpec,
                         PhaseFieldSpec, Scene, SceneError, WallSpec, register_material)
from pfmpm.scene import materials as materials_module
from pfmpm.simulation import Simulation


def plate(material: dict) -> dict:
    return {
        "grid": {"size": [10.0, 4.0], "h": 0.5},
        "time": {"end": 1.0},
        "materials": [material],
        "bodies": [{"name": "plate", "material": material["name"],
                    "shape": {"type": "rectangle", "min": [1.0, 1.0], "max": [9.0, 3.0]}}],
    }


@pytest.fixture
def acoustic(monkeypatch):
    """A test model registered for one test: a wave speed and a density, nothing else."""
    monkeypatch.setattr(materials_module, "MATERIALS", dict(MATERIALS))

    @register_material
    @dataclass(frozen=True)
    class AcousticSpec(MaterialSpec):
        model: ClassVar[str] = "acoustic"
        name: str
        speed: float
        density: float
        fracture: FractureSpec | None = None

        def __post_init__(self):
            if not self.speed > 0:
                raise SceneError("speed", "must be > 0", self.speed)
            self._check_fracture()

        def wave_speed(self, plane):
            return self.speed

        def rayleigh_speed(self):
            return 0.5 * self.speed

        def core_parameters(self, scene):
            return {"speed": self.speed, "density": self.density}

    return AcousticSpec


def test_a_table_without_model_is_linear_elastic():
    scene = Scene.from_dict(plate({"name": "glass", "E": 32000.0, "nu": 0.2, "density": 2450.0}))
    (glass,) = scene.materials
    assert type(glass) is LinearElasticSpec and glass.model == "linear_elastic"
    assert scene.to_dict()["materials"][0]["model"] == "linear_elastic"


def test_a_registered_model_is_read_checked_and_written_by_name(acoustic):
    d = plate({"name": "air", "model": "acoustic", "speed": 2.0, "density": 1.0,
               "fracture": {"Gc": 1.0, "l0": 1.0}})
    scene = Scene.from_dict(d)
    (air,) = scene.materials
    assert isinstance(air, acoustic) and air.fracture.l0 == 1.0
    # Its wave speed sets the step: cfl 0.8 x kappa 0.577 x h 0.5 / speed 2 (bodies clear of
    # the grid sides).
    assert scene.stable_dt() == pytest.approx(0.8 * 0.577 * 0.5 / 2.0)
    assert scene.crack_rayleigh_speed() == 1.0
    assert Scene.from_dict(scene.to_dict()) == scene
    with pytest.raises(SceneError, match=r"^materials\[0\]\.speed = -1\.0: must be > 0$"):
        Scene.from_dict(d, ["materials.air.speed=-1.0"])
    with pytest.raises(SceneError, match=r"^materials\[0\]\.E: unknown key \(allowed: model, name, speed,"):
        Scene.from_dict(d, ["materials.air.E=1.0"])


def test_the_core_refuses_a_model_it_does_not_have_naming_the_key(acoustic):
    scene = Scene.from_dict(plate({"name": "air", "model": "acoustic", "speed": 2.0, "density": 1.0}))
    with pytest.raises(SceneError) as err:
        Simulation(scene)
    assert str(err.value) == ("materials[0].model = 'acoustic': the core has no such model"
                              " (it has drucker_prager, linear_elastic, neo_hookean)")


def test_an_unknown_model_names_the_registered_ones(acoustic):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(plate({"name": "m", "model": "plastic", "E": 1.0, "nu": 0.2, "density": 1.0}))
    assert str(err.value) == ("materials[0].model = 'plastic': must be one of 'linear_elastic',"
                              " 'neo_hookean', 'drucker_prager', 'acoustic'")
    with pytest.raises(SceneError, match=r"^materials\[0\]\.model = \[1\]: must be one of"):
        Scene.from_dict(plate({"name": "m", "model": [1], "E": 1.0, "nu": 0.2, "density": 1.0}))


def test_the_names_before_the_spec_classes_still_import():
    assert pfmpm.scene.Grid is GridSpec and pfmpm.scene.Wall is WallSpec
    assert pfmpm.scene.Fracture is FractureSpec and pfmpm.scene.PhaseField is PhaseFieldSpec
    assert pfmpm.scene.Material is LinearElasticSpec


def test_the_readme_docs_and_notebooks_name_the_spec_classes():
    """Issue 53: one set of names where users read them (the old ones only for old scripts)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    old = r"(Grid|Wall|Fracture|PhaseField|Material)"
    for path in [root / "README.md", *(root / "docs").glob("*.md"), *(root / "docs" / "notebooks").glob("*.ipynb")]:
        text = path.read_text()
        imports = " ".join(re.findall(r"from pfmpm\.scene import \([^)]*\)|from pfmpm\.scene import .*", text))
        assert not re.search(rf"\b{old}\b", imports), path.name
        assert not re.search(rf"(?<![\w.]){old}\(", text), path.name
    assert "GridSpec(" in (root / "README.md").read_text()
