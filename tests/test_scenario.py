"""Scenario files: defaults in one place, closed keys, one-line errors naming file and key."""

from pathlib import Path

import pytest

from acc.scenarios.force import Scenario, ScenarioError, load_scenario, parse_assignment

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "experiments" / "kim_chung_2001.toml"


def test_shipped_scenario_is_the_paper_and_round_trips():
    sc = load_scenario(SHIPPED)
    assert sc.feed_drive.bandwidth_rad_s == 29.33 and sc.feed_drive.dead_time_s == 0.1
    assert sc.force_process.k2_N_min_per_mm_s == (10.05, 12.57, 20.11)
    assert sc.force_process.p2_rad_s == (-2.35, -3.75, -5.35)
    assert sc.workpiece.radial_depth_mm == (2.0, 3.0, 4.0)
    assert sc.delay_steps == 100
    again = Scenario().with_values(
        {f"{sec}.{k}": v for sec, table in sc.to_dict().items() for k, v in table.items()}
    )
    assert again == sc


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[controller]\nkp = 1.0\n", "controller.kp: unknown key; did you mean 'kp_per_N'?"),
        ("[contoller]\nkind = 'pi'\n", "[contoller]: unknown section; did you mean 'controller'?"),
        ("[controller]\nzz = 1.0\n", "controller.zz: unknown key (known: kind,"),
        (
            "[controller]\nreference_force_N = 'high'\n",
            "controller.reference_force_N: expected a number",
        ),
        ("[simulation]\nplant_step_s = 0.0\n", "plant_step_s must be > 0"),
        ("[simulation]\ncontrol_period_s = 0.0015\n", "not a whole multiple of plant_step_s"),
        ("[feed_drive]\ndead_time_s = 0.1005\n", "feed_drive.dead_time_s"),
        ("[workpiece]\nradial_depth_mm = [2.0, 3.0, 5.0]\n", "workpiece.radial_depth_mm"),
        ("[workpiece]\nradial_depth_mm = [2.0, -3.0, 4.0]\n", "depths must be >= 0"),
        ("[controller]\nkind = 'pid'\n", "kind must be one of"),
        (
            "[controller]\nkind = 'dob_pi'\n[nominal_plant]\ndead_time_s = 0.105\n",
            "nominal_plant.dead_time_s",
        ),
        ("[simulation\n", "not valid TOML"),
    ],
)
def test_bad_files_name_file_and_key_in_one_line(tmp_path, text, needle):
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert needle in message
    assert str(path) in message
    assert "\n" not in message


def test_missing_file():
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario("does/not/exist.toml")


def test_dead_time_rounding_policy_rounds_with_a_warning():
    with pytest.warns(UserWarning, match="rounded to 101 steps"):
        sc = Scenario().with_values(
            {"feed_drive.dead_time_s": 0.1006, "simulation.dead_time_rounding": "round"}
        )
        assert sc.delay_steps == 101


def test_parse_assignment_reads_toml_values():
    assert parse_assignment("controller.reference_force_N=450") == (
        "controller.reference_force_N",
        450,
    )
    assert parse_assignment("controller.kind=pi") == ("controller.kind", "pi")
    assert parse_assignment("workpiece.radial_depth_mm=[2, 4]")[1] == [2, 4]
    with pytest.raises(ScenarioError, match="section.key=value"):
        parse_assignment("reference=3")


@pytest.mark.parametrize(
    ("typed", "known", "hint"),
    [
        ("kp", ["kind", "kp_per_N", "ki_per_N_s"], "; did you mean 'kp_per_N'?"),
        ("sensr", ["sensor", "simulation"], "; did you mean 'sensor'?"),
        ("plant_step", ["plant_step_s", "control_period_s"], "; did you mean 'plant_step_s'?"),
        ("zz", ["kind", "kp_per_N"], ""),
    ],
)
def test_did_you_mean_names_the_close_keys_and_only_those(typed, known, hint):
    from acc.errors import did_you_mean

    assert did_you_mean(typed, known) == hint


def test_a_mistyped_campaign_key_is_named_with_its_likely_meaning(tmp_path):
    from acc.campaigns.campaign import CampaignError, load_campaign

    path = tmp_path / "c.toml"
    path.write_text(
        f'[campaign]\nbse = "{Path("experiments/kim_chung_2001.toml").resolve()}"\n'
    )
    with pytest.raises(CampaignError, match=r"campaign.bse: unknown key; did you mean 'base'"):
        load_campaign(path)


@pytest.mark.parametrize(
    ("item", "needle"),
    [
        (float("nan"), "workpiece.radial_depth_mm[1]: must be a finite number, got nan"),
        (float("-inf"), "workpiece.radial_depth_mm[1]: must be a finite number, got -inf"),
        (1e300, "workpiece.radial_depth_mm[1]: magnitude of 1e+300 is outside"),
        (1e-300, "workpiece.radial_depth_mm[1]: magnitude of 1e-300 is outside"),
        (True, "workpiece.radial_depth_mm[1]: expected a number, got True"),
        ("3", "workpiece.radial_depth_mm[1]: expected a number, got '3'"),
    ],
)
def test_a_bad_list_item_is_named_with_its_index(item, needle):
    """Each item of a list of numbers is checked as a single number is, and the message
    names the item (a sweep's drawn depth profile goes through the same conversion)."""
    with pytest.raises(ScenarioError) as err:
        Scenario().with_values({"workpiece.radial_depth_mm": [3.0, item, 2.0]})
    assert needle in str(err.value)


def test_list_items_become_python_floats():
    """Whole numbers and NumPy floats in a list of numbers become Python floats; 0 and -0
    pass (0 is exempt from the magnitude range)."""
    import numpy as np

    sc = Scenario().with_values(
        {"workpiece.radial_depth_mm": [3, np.float64(2.5), 0.0, -0.0],
         "workpiece.segment_length_mm": [10.0, 10.0, 10.0, 10.0],
         "workpiece.axial_depth_mm": [10.0, 10.0, 10.0, 10.0]})
    depths = sc.workpiece.radial_depth_mm
    assert depths == (3.0, 2.5, 0.0, 0.0)
    assert [type(d) for d in depths] == [float] * 4
