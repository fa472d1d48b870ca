"""Force process, Eq. (7) and Table 1; nominal plant, Eq. (9)."""

import numpy as np
import pytest
from scipy.linalg import expm

from plants.force_process import ForceProcessTable, OutOfTableError, cascade_coefficients
from plants.nominal_plant import NominalPlant


def test_eq9_gain_is_29_33_times_12_57():
    # the paper prints 368.68; 29.33 * 12.57 = 368.6781
    assert round(NominalPlant().gain, 2) == 368.68
    assert NominalPlant().static_gain_N_per_mm_min == pytest.approx(12.57 / 3.75)


def test_table_rows_exact_and_linear_between():
    table = ForceProcessTable()
    k2, p2 = table.parameters([2.0, 3.0, 4.0])
    assert np.array_equal(k2, [10.05, 12.57, 20.11])
    assert np.array_equal(p2, [-2.35, -3.75, -5.35])
    k2, p2 = table.parameters([2.5])
    assert k2[0] == pytest.approx((10.05 + 12.57) / 2)
    assert p2[0] == pytest.approx((-2.35 - 3.75) / 2)
    assert table.static_gain_N_per_mm_min([0.0, 3.0])[0] == 0.0


def test_out_of_table_error_clamp_extrapolate():
    with pytest.raises(OutOfTableError, match="outside the process table"):
        ForceProcessTable().parameters([5.0])
    clamp = ForceProcessTable(out_of_table="clamp")
    assert clamp.parameters([5.0])[0][0] == 20.11
    extra = ForceProcessTable(out_of_table="extrapolate")
    assert extra.parameters([5.0])[0][0] == pytest.approx(20.11 + (20.11 - 12.57))
    assert extra.parameters([5.0])[1][0] == pytest.approx(-5.35 - 1.6)
    with pytest.raises(OutOfTableError, match="negative"):
        ForceProcessTable().check_depth(-1.0)


def test_gain_multiplier_scales_k2_only():
    k2, p2 = ForceProcessTable(gain_multiplier=3.0).parameters([3.0])
    assert k2[0] == pytest.approx(3 * 12.57) and p2[0] == -3.75


@pytest.mark.parametrize("p2", [-2.35, -3.75, -29.33, -29.33 + 1e-14, -60.0])
def test_cascade_coefficients_equal_the_matrix_exponential(p2):
    """Independent computation: expm of the augmented [A B; 0 0] matrix of (v, x) with input u."""
    a, dt = 29.33, 0.001
    A = np.array([[-a, 0.0], [-p2, p2]])
    B = np.array([[a], [0.0]])
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2:] = A, B
    E = expm(M * dt)
    phi, c_v, c_u = cascade_coefficients(p2, a, dt)
    assert phi == pytest.approx(E[1, 1], rel=1e-12)
    assert c_v == pytest.approx(E[1, 0], rel=1e-10, abs=1e-15)
    assert c_u == pytest.approx(E[1, 2], rel=1e-10, abs=1e-15)


def test_chip_load_equals_feed_velocity_in_air():
    from acc.engine.element import output_runs, step_runs
    from plants.feed_drive import feed_drive_records
    from plants.force_process import force_process_records

    dt = 0.001
    dp, ds = feed_drive_records(29.33, 10, dt)
    pp, ps = force_process_records(np.array([[0.0, 3.35]]), np.array([[-2.35, -3.75]]), [29.33], dt)
    air = 0
    for _ in range(200):
        v, delayed, _ = step_runs(dp, ds, [150.0])
        step_runs(pp, ps, [air], v, delayed)
        force, _, _ = output_runs(pp, ps, [air], [0], [0.0])
        assert force[0] == 0.0
        assert ps["chip_load_mm_min"][0] == pytest.approx(
            ds["velocity_mm_min"][0], rel=1e-14, abs=1e-14
        )


def test_axial_depth_scales_the_table_gain_as_the_geometric_average_does():
    """Without edge forces the geometric model's tooth-period average force is exactly
    proportional to the axial depth (Eq. 2 integrated over the helix), so its static gain
    ratio between two axial depths is the depth ratio; the table model's must equal it."""
    from plants.cutting_coefficients import CuttingCoefficients
    from plants.end_mill_geometry import EndMill, MillingCut, force_process_static_gain_N_per_mm_min

    table = ForceProcessTable()
    radial = np.array([2.0, 3.0, 4.0, 0.0])
    axial = np.array([4.0, 10.0, 17.5, 12.0])
    gain, pole = table.segment_parameters(radial, axial)
    at_reference, _ = table.segment_parameters(radial)
    k = CuttingCoefficients(tangential_edge_N_mm=0.0, radial_edge_N_mm=0.0, axial_edge_N_mm=0.0)
    tool = EndMill()
    for i in range(3):
        geo = [
            float(force_process_static_gain_N_per_mm_min(
                tool, MillingCut(radial[i], a, 0.05), k, "resultant_xy"
            ))
            for a in (axial[i], table.reference_axial_depth_mm)
        ]
        assert gain[i] / at_reference[i] == pytest.approx(geo[0] / geo[1], rel=1e-12)
    assert gain[3] == 0.0  # radial 0: air, whatever the axial depth
    assert gain[0] == pytest.approx(at_reference[0] * 0.4, rel=1e-15)
    np.testing.assert_array_equal(pole[:3], table.parameters(radial[:3])[1])


def test_zero_axial_depth_is_air():
    gain, _ = ForceProcessTable().segment_parameters([3.0], [0.0])
    assert gain[0] == 0.0


@pytest.mark.parametrize("policy", ["error", "clamp", "extrapolate"])
def test_parts_at_once_equal_each_part_alone(policy):
    """segment_parameters of a (parts, segments) array, as a batch computes it, is each part's
    own call bit for bit (air, zero axial depth and, but for "error", depths off the table)."""
    table = ForceProcessTable(out_of_table=policy)
    rng = np.random.default_rng(3)
    hi = 4.0 if policy == "error" else 5.5
    radial = rng.uniform(1.0 if policy != "error" else 2.0, hi, (40, 4))
    radial[:, 3] = 0.0  # the air after the part
    radial[5, 1] = 0.0
    axial = rng.uniform(5.0, 15.0, (40, 4))
    axial[7, 2] = 0.0
    gain, pole = table.segment_parameters(radial, axial)
    for i in range(40):
        g, p = table.segment_parameters(radial[i], axial[i])
        assert np.array_equal(gain[i], g) and np.array_equal(pole[i], p)
        # and as a single part's gain is written down: K2 / (-p2) x axial / 10 mm, in cut
        cut = (radial[i] > 0) & (axial[i] > 0)
        k2, p2 = table.parameters(radial[i][cut])
        assert np.array_equal(g[cut], k2 / (-p2) * (axial[i][cut] / 10.0))
        assert np.array_equal(p[cut], p2)
        assert np.all(g[~cut] == 0.0) and np.all(p[~cut] == table.p2_rad_s[0])


def test_the_first_depth_off_the_table_is_the_one_named():
    table = ForceProcessTable()
    depths = np.array([[2.0, 3.0, 0.0], [2.5, 4.5, 1.5], [-1.0, 3.0, 0.0]])
    with pytest.raises(OutOfTableError, match=r"radial depth 4\.5 mm is outside"):
        table.segment_parameters(depths)
    with pytest.raises(OutOfTableError, match=r"radial depth -1\.0 mm is negative"):
        table.check_depths(depths[2:])
    table.check_depths([np.nan, 0.0, 2.0, 4.0])  # NaN and air pass, as check_depth lets them


@pytest.mark.parametrize("policy", ["error", "clamp", "extrapolate"])
@pytest.mark.parametrize(
    "table_rows",
    [
        None,  # Table 1
        ((1.0, 2.5, 3.1, 6.0), (3.0, 7.7, 9.1, 30.3), (-1.1, -2.9, -3.3, -9.7)),
        ((3.0,), (12.0,), (-3.0,)),  # one row: every depth has its gain
    ],
)
def test_largest_static_gain_is_the_array_paths_maximum_bit_for_bit(policy, table_rows):
    """The scalar path the validation takes (largest_static_gain_N_per_mm_min) equals the
    maximum of static_gain_N_per_mm_min over the cut depths, bit for bit: between rows, on
    rows (numpy.interp returns a row's value as it is), beyond the ends (clamped or
    extrapolated), with air among the depths, with a gain multiplier; NaN for an air part."""
    rows = {} if table_rows is None else dict(
        zip(("radial_depth_mm", "k2_N_min_per_mm_s", "p2_rad_s"), table_rows, strict=True))
    table = ForceProcessTable(out_of_table=policy, gain_multiplier=1.37, **rows)
    lo, hi = table.radial_depth_mm[0], table.radial_depth_mm[-1]
    rng = np.random.default_rng(11)
    compared = 0
    for _ in range(2000):
        n = int(rng.integers(1, 5))
        if policy == "error":  # (one row: the row's depth)
            d = rng.uniform(lo, hi, n)
        else:
            d = rng.uniform(0.8 * lo, 1.3 * hi, n)
        if rng.random() < 0.3:
            d[0] = rng.choice(table.radial_depth_mm)
        if rng.random() < 0.2:
            d[-1] = 0.0
        try:
            gains = table.static_gain_N_per_mm_min(d)
        except OutOfTableError:  # a depth the validation refuses before asking
            continue
        expected = gains[d > 0].max() if (d > 0).any() else np.nan
        got = table.largest_static_gain_N_per_mm_min(d.tolist())
        assert got == expected or (np.isnan(got) and np.isnan(expected)), (d, got, expected)
        compared += 1
    assert compared > 1500
    assert np.isnan(table.largest_static_gain_N_per_mm_min([0.0, 0.0]))
