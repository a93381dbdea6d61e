"""The YAML loader: built-in files load; every kind of bad value is named with file and key."""

from pathlib import Path

import pytest

from kinegym import configs
from kinegym.configs import ConfigError
from kinegym.kinematics import ClimberGeometry, HoleMap, WritingArm


@pytest.mark.parametrize("kind", ["arms", "robots", "walls"])
def test_builtin_configs_listed(kind: str) -> None:
    assert configs.available(kind)


def test_builtin_configs_load() -> None:
    assert WritingArm.from_config("pincher").upper_arm == 10.7
    assert WritingArm.from_config("thesis_rrrr").lateral_offset == 3.0
    assert ClimberGeometry.from_config("climber").l1.tolist() == [10.0, 10.0, 10.0]
    wall = HoleMap.from_config("seed_4x4")
    assert len(wall) == 16
    assert wall.position((3, 1)).tolist() == [40.0, 0.00000001]  # the seed's odd 1e-8, kept


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    return p


PINCHER = (configs.CONFIG_DIR / "arms" / "pincher.yaml").read_text()


@pytest.mark.parametrize(
    ("old", "new", "key", "value"),
    [
        ("upper_arm_cm: 10.7", "upper_arm_cm: -1", "upper_arm_cm", -1),
        ("upper_arm_cm: 10.7", "upper_arm_cm: .nan", "upper_arm_cm", None),
        ("tool_cm: 9.5", "tool_cm: long", "tool_cm", "long"),
        ("name: pincher", "name: pincher\nwrist_cm: 3", "wrist_cm", 3),
        ("servo_sign: [1, -1, -1, -1]", "servo_sign: [1, -1, -1]", "servo_sign", [1, -1, -1]),
        ("servo_sign: [1, -1, -1, -1]", "servo_sign: [1, 0, -1, -1]", "servo_sign[1]", 0),
        ("[[-150, 150], [-150, 150]", "[[150, -150], [-150, 150]", "servo_limits_deg[0]", None),
    ],
)
def test_bad_values_are_named(tmp_path: Path, old: str, new: str, key: str, value: object) -> None:
    assert old in PINCHER
    path = _write(tmp_path, PINCHER.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        WritingArm.from_config(path)
    err = info.value
    assert err.key == key
    assert str(path) in str(err) and key in str(err)
    if value is not None:
        assert err.value == value


def test_missing_required_key(tmp_path: Path) -> None:
    path = _write(tmp_path, "\n".join(ln for ln in PINCHER.splitlines() if "forearm_cm" not in ln))
    with pytest.raises(ConfigError, match="forearm_cm"):
        WritingArm.from_config(path)


def test_unknown_name_lists_builtins() -> None:
    with pytest.raises(ConfigError, match="pincher") as info:
        WritingArm.from_config("no_such_arm")
    assert "thesis_rrrr" in str(info.value)


def test_unparsable_yaml(tmp_path: Path) -> None:
    path = _write(tmp_path, "name: [unclosed\n")
    with pytest.raises(ConfigError, match="valid YAML"):
        WritingArm.from_config(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="existing YAML file"):
        HoleMap.from_config(tmp_path / "nope.yaml")


def test_climber_needs_three_arms(tmp_path: Path) -> None:
    path = _write(tmp_path, "arms:\n  - {upper_link_cm: 10}\n  - {upper_link_cm: 10}\n")
    with pytest.raises(ConfigError, match="arms") as info:
        ClimberGeometry.from_config(path)
    assert "3 items" in str(info.value)


def test_wall_duplicate_ids(tmp_path: Path) -> None:
    path = _write(tmp_path, "holes:\n  - {id: [1, 1], xy_cm: [0, 0]}\n  - {id: [1, 1], xy_cm: [5, 0]}\n")
    with pytest.raises(ConfigError, match="more than once"):
        HoleMap.from_config(path)
