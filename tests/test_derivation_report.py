"""The referee checks behind docs/derivation.md (codegen/report.py): each computed outcome is asserted."""
from __future__ import annotations

import pytest

from codegen import report


@pytest.fixture(scope="module")
def checks():
    return {c.eqs: c for c in report.run_checks()}


def outcome(checks, eqs, name):
    return checks[eqs].outcomes[name]


def test_no_check_contradicts_its_expectation(checks):
    for c in checks.values():
        assert report.FAILED not in c.verdict, (c.eqs, c.verdict, c.evidence)
        assert c.evidence, c.eqs


def test_definitions_confirmed(checks):
    assert outcome(checks, "12–13", "eq13_matches_latdyn")
    assert outcome(checks, "7, 14–16", "eq14_16_first_order")
    assert outcome(checks, "17", "eq17") and outcome(checks, "17", "eq17_latdyn_axis")
    assert outcome(checks, "47", "eq47")
    assert outcome(checks, "39–42", "eq40") and outcome(checks, "39–42", "eq40_latdyn")


def test_exact_frame_is_first_order_form_of_eqs_19_21(checks):
    assert outcome(checks, "19–21", "eq19_21_first_order")
    assert outcome(checks, "19–21", "exact_frame_orthonormal")
    assert not outcome(checks, "19–21", "printed_frame_orthonormal")


def test_shape_functions_need_dimensionless_a(checks):
    assert not outcome(checks, "22–26", "printed_slopes")
    assert outcome(checks, "22–26", "dimensionless_slopes")
    assert not outcome(checks, "22–26", "eq22_printed_rotates_section")
    assert outcome(checks, "22–26", "eq22_with_prime")


def test_bending_stiffness(checks):
    assert outcome(checks, "28–32", "eq31_values")
    assert outcome(checks, "28–32", "eq29_gradient")
    assert not outcome(checks, "28–32", "eq32_factor")
    assert outcome(checks, "28–32", "latdyn_bending")


def test_eq38_values():
    f = report.stretch_forces()
    L = report.L
    assert list(f["Ahat"]) == [report.sp.Rational(2, 15), report.sp.Rational(-1, 30),
                               report.sp.Rational(-1, 30), report.sp.Rational(2, 15)]
    assert f["Ap"][0, 0] == report.sp.Rational(2, 15) * L**2


def test_eq37(checks):
    assert outcome(checks, "37–38", "eq37_corrected_is_frozen_gradient")
    assert not outcome(checks, "37–38", "eq37_printed_is_frozen_gradient")
    assert not outcome(checks, "37–38", "eq37_conservative")
    assert outcome(checks, "37–38", "latdyn_conservative")
    assert outcome(checks, "37–38", "latdyn_first_order")
    assert outcome(checks, "37–38", "latdyn_vs_exact")


def test_eq45(checks):
    assert outcome(checks, "44–46", "latdyn_equals_definition")
    assert not outcome(checks, "44–46", "printed_equals_definition")
    assert not outcome(checks, "44–46", "printed_twist_at_node1")


def test_eq49_printed_fails_corrected_passes(checks):
    c = checks["49"]
    assert not c.outcomes["printed_is_rotation"]
    assert not c.outcomes["printed_satisfies_eq6"]
    assert not c.outcomes["sign_only_satisfies_eq6"]
    assert c.outcomes["corrected_satisfies_eq6"]


def test_eq50_and_eq53(checks):
    assert not outcome(checks, "50–51", "printed_literal")
    assert not outcome(checks, "50–51", "printed_with_eq49_fixed")
    assert outcome(checks, "50–51", "corrected")
    assert outcome(checks, "52–53", "structure_exact")
    assert outcome(checks, "52–53", "closed_form_first_order")
    assert not outcome(checks, "52–53", "closed_form_eq7_only")
    assert not outcome(checks, "52–53", "without_second_derivatives")


def test_inertia_and_offsets(checks):
    assert outcome(checks, "54–57", "twist_inertia_volume")
    assert outcome(checks, "54–57", "eq55_identity")
    assert outcome(checks, "58", "eq58_signs")
    assert outcome(checks, "59–61", "eq59")
    assert outcome(checks, "59–61", "eq61_plus")
    assert not outcome(checks, "59–61", "eq61_printed_sign")
    assert outcome(checks, "62", "eq62")


def test_log_measure(checks):
    """The default variant's exact local rotations (the deviation from Eqs. 14–16): Rodrigues, the series
    and branch-free scale, the sines' second-order error, the twist at node 1, pure bending exact, and the
    corotational frame: node 1's reads both ends' bending a quarter of the element twist off the mid-section
    (issue 22's first-order bending–twist coupling), the mean frame reads it there (to O(ε³))."""
    c = checks["14–16 (log)"]
    assert c.verdict == report.CHOICE, (c.verdict, c.evidence)
    for name in ("rodrigues", "series", "branch_free_accuracy", "sines_differ_second_order", "twist_node1",
                 "pure_bending_exact", "pure_bending_sine_error", "frame_range",
                 "node1_closed_form", "first_node_frame_quarter_twist", "mean_frame_exact_second_order",
                 "mean_frame_closed_form"):
        assert c.outcomes[name], (name, c.evidence)


@pytest.mark.parametrize("variant", report.NUMERIC_VARIANTS)
def test_generated_kernels_numerically(variant):
    res = report.numerical_evidence(variant=variant)
    if not res["available"]:
        pytest.skip(res["why"])
    rows = {name: ok for name, _, _, ok, _ in res["rows"]}
    assert not rows.pop("Eq. 62 g with printed χ")
    assert all(rows.values()), res["rows"]


def test_write_report(tmp_path):
    path = tmp_path / "docs" / "derivation.md"
    report.write_report(path)
    text = path.read_text(encoding="utf-8")
    assert "## Conventions" in text and "## Numerical evidence" in text
    assert report.FAILED not in text.split("## Numerical evidence")[0]
    for eq in ("Eq. 14–16 (log)", "Eq. 37–38", "Eq. 49", "Eq. 59–61", "Eq. 62"):
        assert eq in text
    for variant in report.NUMERIC_VARIANTS:
        assert f"### Variant `{variant}`" in text


def test_shear_extension(checks):
    """The interdependent interpolation element (SCENE.md GAy, GAz): derived shapes, energy, one-element cantilever."""
    for name in ("iie_equilibrium", "iie_ends", "iie_hermite_limit", "iie_energy", "latdyn_energy",
                 "one_element_cantilever", "iie_stretching"):
        assert outcome(checks, "28–32 (shear)", name), name
