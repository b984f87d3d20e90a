"""The symbolic error model: Phi two ways, closed form vs numerical integration, audit pins.

Independent evidence used here: scipy.linalg.expm of the numeric F, scipy's
solve_ivp (DOP853) of the error ODE written out by hand, a nonlinear strapdown
of a body at rest with biased sensors, Gaussian moments and a seeded Monte Carlo.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from morpi_filters import MorpiError
from morpi_filters import symbolic as S
from morpi_filters.params import params_from_dict

PHYSICAL = [c for c in S.AUDIT_CONVENTIONS if c.physical]


# ----------------------------------------------------------------------------- helpers (independent of sympy)

def skew_np(v):
    x, y, z = v
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0.0]])


def F_numeric(conv, C, f):
    """15x15 F written out with numpy (state dp, dv, eps, b_a, b_g)."""
    F = np.zeros((15, 15))
    F[0:3, 3:6] = np.eye(3)
    F[3:6, 6:9] = conv.misalignment_sign * skew_np(f)
    F[3:6, 9:12] = C
    F[6:9, 12:15] = conv.gyro_sign * C
    return F


def ode_dp(conv, dv, ba, bg, g, times):
    """dp(t) of the 3D error ODE under the paper's assumptions, by DOP853."""
    f = np.array([ba[0], ba[1], conv.gravity_sign * g + ba[2]])
    F = F_numeric(conv, np.eye(3), f)
    x0 = np.concatenate([np.zeros(3), dv, np.zeros(3), ba, bg])
    sol = solve_ivp(lambda t, x: F @ x, (0.0, max(times)), x0, method="DOP853", t_eval=times,
                    rtol=1e-13, atol=1e-16)
    assert sol.success
    return sol.y[0:3].T


def ode_dp_2d(conv, dv, ba, bgz, times):
    """dp(t) of the yaw-only 2D INS error ODE (state dp_xy, dv_xy, eps_z), by DOP853."""
    sm, sg = conv.misalignment_sign, conv.gyro_sign

    def rhs(t, x):
        ez = x[4]
        # (f x eps) with eps = (0, 0, ez): x -> f_y ez, y -> -f_x ez
        return [x[2], x[3], sm * ba[1] * ez + ba[0], -sm * ba[0] * ez + ba[1], sg * bgz]

    sol = solve_ivp(rhs, (0.0, max(times)), [0, 0, dv[0], dv[1], 0], method="DOP853", t_eval=times,
                    rtol=1e-13, atol=1e-16)
    assert sol.success
    return sol.y[0:2].T


def random_draw(rng):
    """Every component non-zero, random signs, magnitudes of a low-cost IMU."""
    sign = lambda n: rng.choice([-1.0, 1.0], n)  # noqa: E731
    dv = sign(3) * rng.uniform(0.01, 0.3, 3)
    ba = sign(3) * rng.uniform(0.005, 0.5, 3)
    bg = sign(3) * rng.uniform(1e-4, 0.05, 3)
    return dv, ba, bg


# ----------------------------------------------------------------------------- Phi

@pytest.mark.parametrize("conv", PHYSICAL + [S.Convention("z_up", -1, -1)], ids=lambda c: c.name)
def test_phi_block_form_equals_exponential_and_solves_the_ode(conv):
    chk = S.verify_phi(conv)
    assert chk == S.PhiCheck(True, True, True)


@pytest.mark.parametrize("conv", [S.Convention("z_up"), S.Convention("z_up", 1, -1)], ids=lambda c: c.name)
def test_time_varying_block_form_solves_the_ode(conv):
    chk = S.verify_phi(conv, time_varying=True)
    assert chk.ode and chk.initial_identity and chk.block_equals_exponential is None


def test_ode_check_can_fail():
    # Phi of one sign convention against F of another must not satisfy dPhi/dt = F Phi
    s = S.symbols()
    Phi = S.phi_block_form("z_up", time_varying=True)
    F = S.system_matrix_symbols(S.Convention("z_up", 1, 1), time_varying=True)
    d = Phi.diff(s.t) - F * Phi
    assert not all(sp.expand(e.as_dummy()) == 0 for e in d)


def test_F_is_built_from_the_paper_blocks():
    F = S.system_matrix_symbols("z_up")
    C, f = S._generic_C_f(False)
    assert F[0:3, 3:6] == sp.eye(3)
    assert F[3:6, 6:9] == -S.skew_symbols(f)  # -(f^n x), the paper's sign
    assert F[3:6, 9:12] == C and F[6:9, 12:15] == C
    assert (F**4).is_zero_matrix and not (F**3).is_zero_matrix


def test_phi_numeric_matches_scipy_expm():
    rng = np.random.default_rng(20231)
    worst = 0.0
    for conv in PHYSICAL:
        for _ in range(10):
            C = Rotation.random(random_state=rng).as_matrix()
            f = rng.normal(0.0, 5.0, 3)
            t = rng.uniform(0.1, 20.0)
            ref = expm(F_numeric(conv, C, f) * t)
            got = S.phi_numeric(C, f, t, conv)
            worst = max(worst, np.linalg.norm(got - ref) / np.linalg.norm(ref))
    # 1e-12: the acceptance bar; both sides are exact up to rounding (F is nilpotent)
    assert worst < 1e-12


@pytest.mark.parametrize("conv", S.AUDIT_CONVENTIONS, ids=lambda c: c.name)
def test_series_phi_with_symbols_matches_scipy_expm(conv):
    """The symbolic series Phi (generic C_ij, f_i, t, t0), evaluated at random values, is expm(F tau)."""
    rng = np.random.default_rng(7)
    s = S.symbols()
    Phi = S.phi_exponential(conv)
    C_sym, f_sym = S._generic_C_f(False)
    fn = sp.lambdify((s.t, s.t0, tuple(C_sym), tuple(f_sym)), Phi, modules="numpy")
    for _ in range(5):
        C = Rotation.random(random_state=rng).as_matrix()
        f = rng.normal(0.0, 5.0, 3)
        t0 = rng.uniform(-5.0, 5.0)
        t = t0 + rng.uniform(0.1, 20.0)
        got = np.asarray(fn(t, t0, tuple(C.ravel()), tuple(f)), float)
        ref = expm(F_numeric(conv, C, f) * (t - t0))
        # 1e-12: both sides exact up to rounding (F is nilpotent, the series ends at F^3)
        assert np.linalg.norm(got - ref) / np.linalg.norm(ref) < 1e-12


def test_series_phi_refuses_a_time_varying_model():
    s = S.symbols()
    with pytest.raises(ValueError):
        S.phi_exponential("z_up", f=[0, 0, s.t])


# ----------------------------------------------------------------------------- closed form vs ODE

@pytest.mark.parametrize("conv", S.AUDIT_CONVENTIONS, ids=lambda c: c.name)
def test_closed_form_dp_matches_solve_ivp(conv):
    rng = np.random.default_rng(7)
    times = np.array([0.5, 2.0, 5.0, 9.0, 15.0])
    for _ in range(4):
        dv, ba, bg = random_draw(rng)
        p = params_from_dict({"dv0_mps": list(dv), "accel_bias_mps2": list(ba), "gyro_bias_radps": list(bg), "g_mps2": 9.81})
        got = S.closed_form_errors(p, times, "INS-3D position", conv, keep_bgz=True)
        ref = ode_dp(conv, dv, ba, bg, 9.81, times)
        rel = np.linalg.norm(got - ref, axis=1) / np.linalg.norm(ref, axis=1)
        # 1e-9: the acceptance bar; DOP853 at rtol 1e-13 is good to ~1e-12 here
        assert rel.max() < 1e-9
        # distance errors are the horizontal norms, with and without b_gz
        e3 = S.closed_form_errors(p, times, "INS-3D", conv, keep_bgz=True)
        np.testing.assert_allclose(e3, np.linalg.norm(ref[:, :2], axis=1), rtol=1e-9)
        bg0 = np.array([bg[0], bg[1], 0.0])
        ref0 = ode_dp(conv, dv, ba, bg0, 9.81, times)
        e3d = S.closed_form_errors(p, times, "INS-3D", conv, keep_bgz=False)
        np.testing.assert_allclose(e3d, np.linalg.norm(ref0[:, :2], axis=1), rtol=1e-9)  # DOP853 at rtol 1e-12 over the span; 1e-9 leaves room for the accumulated solver error


@pytest.mark.parametrize("conv", PHYSICAL, ids=lambda c: c.name)
def test_closed_form_2d_matches_the_yaw_only_ode(conv):
    rng = np.random.default_rng(11)
    times = np.array([1.0, 5.0, 14.0])
    for _ in range(3):
        dv, ba, bg = random_draw(rng)
        p = params_from_dict({"dv0_mps": list(dv), "accel_bias_mps2": list(ba), "gyro_bias_radps": list(bg), "g_mps2": 9.81})
        ref = ode_dp_2d(conv, dv, ba, bg[2], times)
        np.testing.assert_allclose(S.closed_form_errors(p, times, "INS-2D position", conv, keep_bgz=True), ref, rtol=1e-9)  # DOP853 at rtol 1e-12 over the span; 1e-9 leaves room for the accumulated solver error
        np.testing.assert_allclose(S.closed_form_errors(p, times, "INS-2D", conv, keep_bgz=True),
                                   np.linalg.norm(ref, axis=1), rtol=1e-9)  # DOP853 at rtol 1e-12 over the span; 1e-9 leaves room for the accumulated solver error
        ref0 = ode_dp_2d(conv, dv, ba, 0.0, times)
        np.testing.assert_allclose(S.closed_form_errors(p, times, "INS-2D", conv), np.linalg.norm(ref0, axis=1),
                                   rtol=1e-9)  # DOP853 at rtol 1e-12 over the span; 1e-9 leaves room for the accumulated solver error


def test_z_up_closed_form_matches_a_nonlinear_strapdown_at_rest():
    """Body level at rest, biased IMU; the estimate integrates the nonlinear equations.

    With b_g = measured - true and C_est(0) = C_true = I, C_est(t) = expm(skew(b_g) t);
    v_dot = C_est (f_true + b_a) + g^n with g^n = (0, 0, -g) (package frames).
    """
    g = 9.81
    dv = np.array([0.02, -0.03, 0.01])
    ba = np.array([2e-3, -1e-3, 1.5e-3])
    bg = np.array([2e-4, 3e-4, -2.5e-4])
    f_true = np.array([0.0, 0.0, g])

    def rhs(t, x):
        C = expm(skew_np(bg) * t)
        return np.concatenate([x[3:6], C @ (f_true + ba) + np.array([0, 0, -g])])

    times = np.array([2.0, 5.0, 10.0])
    sol = solve_ivp(rhs, (0, 10.0), np.concatenate([np.zeros(3), dv]), method="DOP853", t_eval=times,
                    rtol=1e-12, atol=1e-14)
    p = params_from_dict({"dv0_mps": list(dv), "accel_bias_mps2": list(ba), "gyro_bias_radps": list(bg), "g_mps2": g})
    ok = S.closed_form_errors(p, times, "INS-3D position", "z_up", keep_bgz=True)
    rel = np.linalg.norm(ok - sol.y[0:3].T, axis=1) / np.linalg.norm(sol.y[0:3].T, axis=1)
    # neglected: second order in the tilt, |b_g| t <= 5e-3 rad -> relative 1e-2 with margin
    assert rel.max() < 1e-2
    # a sign pair with k = +1 gets the tilt term wrong by far more than that
    bad = S.closed_form_errors(p, times, "INS-3D position", S.Convention("z_up", -1, -1), keep_bgz=True)
    assert (np.linalg.norm(bad - sol.y[0:3].T, axis=1) / np.linalg.norm(sol.y[0:3].T, axis=1)).max() > 0.1


# ----------------------------------------------------------------------------- mean square

SIG = {"dv0_mps": [0.05, 0.08, 0.02], "accel_bias_mps2": [0.04, 0.03, 0.06], "gyro_bias_radps": [2e-3, 3e-3, 4e-3],
       "g_mps2": 9.81}


def test_linearized_mean_square_is_the_textbook_sum():
    t = np.array([0.0, 1.0, 5.0, 14.0])
    s = SIG
    g = 9.81
    ex = sum(s["dv0_mps"][i] ** 2 * t**2 + s["accel_bias_mps2"][i] ** 2 * t**4 / 4 for i in (0, 1))
    ex3 = ex + g**2 * (s["gyro_bias_radps"][0] ** 2 + s["gyro_bias_radps"][1] ** 2) * t**6 / 36
    for conv in ("z_up", "z_down"):
        np.testing.assert_allclose(S.closed_form_mean_square(SIG, t, "INS-3D", conv), ex3, rtol=1e-12)  # the same polynomial expanded by hand: float rounding
        np.testing.assert_allclose(S.closed_form_mean_square(SIG, t, "INS-2D", conv), ex, rtol=1e-12)  # the same polynomial expanded by hand: float rounding


def test_full_mean_square_adds_the_product_terms():
    t = np.array([1.0, 5.0, 14.0])
    s = SIG
    lin = S.closed_form_mean_square(SIG, t, "INS-3D", "z_up", linearized=True)
    full = S.closed_form_mean_square(SIG, t, "INS-3D", "z_up", linearized=False, keep_bgz=True)
    bax, bay, baz = s["accel_bias_mps2"]
    bgx, bgy, bgz = s["gyro_bias_radps"]
    extra = (baz**2 * (bgx**2 + bgy**2) + (bax**2 + bay**2) * bgz**2) * t**6 / 36
    # compared as sums (not differences) so that rtol 1e-12 is float rounding only
    np.testing.assert_allclose(full, lin + extra, rtol=1e-12)
    np.testing.assert_allclose(S.closed_form_mean_square(SIG, t, "INS-2D", "z_up", linearized=False, keep_bgz=True),
                               S.closed_form_mean_square(SIG, t, "INS-2D", "z_up")
                               + (bax**2 + bay**2) * bgz**2 * t**6 / 36, rtol=1e-12)  # the same polynomial expanded by hand: float rounding


def test_full_mean_square_against_monte_carlo():
    rng = np.random.default_rng(4242)
    n = 200_000
    fn = S.lambdified("INS-3D", "z_up", True)
    sd = np.array(SIG["dv0_mps"] + SIG["accel_bias_mps2"] + SIG["gyro_bias_radps"])
    draws = rng.normal(size=(n, 9)) * sd
    t = 10.0
    e2 = fn(t, *draws.T, 9.81) ** 2
    est, se = e2.mean(), e2.std() / np.sqrt(n)
    ms = S.closed_form_mean_square(SIG, [t], "INS-3D", "z_up", linearized=False, keep_bgz=True)[0]
    # 5 standard errors of the sample mean
    assert abs(est - ms) < 5 * se


# ----------------------------------------------------------------------------- conventions and errors

def test_convention_names_round_trip():
    for c in S.AUDIT_CONVENTIONS:
        assert S.convention(c.name) == c
    assert S.convention("z_up").name == "z_up" and S.Convention("z_down", 1, -1).name == "z_down,mis+1,gyro-1"


@pytest.mark.parametrize("bad", ["up", "z_up,foo", 3, "z_up,mis+2"])
def test_bad_convention_is_one_clear_error(bad):
    with pytest.raises(MorpiError, match="convention"):
        S.convention(bad)


def test_bad_kind():
    with pytest.raises(MorpiError, match="kind"):
        S.closed_form_errors(SIG, [1.0], "4d")


def test_numeric_functions_need_no_sympy_in_their_results():
    out = S.closed_form_errors(SIG, np.arange(3.0), "INS-3D")
    assert out.dtype == float and out.shape == (3,) and out[0] == 0.0


# ----------------------------------------------------------------------------- audit pins

def polarize(fn, values, powers):
    """Coefficient of prod(values[k] ** powers[k]) in fn, by flipping the signs of odd-power variables.

    Valid when fn (with only these variables non-zero) has no other monomial with the
    same parity pattern, which holds for the error polynomials used here.
    """
    import itertools

    odd = [k for k in values if powers[k] % 2]
    acc = 0.0
    for signs in itertools.product((1, -1), repeat=len(odd)):
        kw = dict(values)
        kw.update({k: s * values[k] for k, s in zip(odd, signs)})
        acc += np.prod(signs) * fn(kw)
    return acc / (2 ** len(odd) * np.prod([values[k] ** powers[k] for k in values]))


def ode_value(conv, which, t, **kw):
    dv = np.array([kw.get("dv_x", 0.0), kw.get("dv_y", 0.0), 0.0])
    ba = np.array([kw.get("b_ax", 0.0), kw.get("b_ay", 0.0), kw.get("b_az", 0.0)])
    bg = np.array([kw.get("b_gx", 0.0), kw.get("b_gy", 0.0), kw.get("b_gz", 0.0)])
    dp = ode_dp(conv, dv, ba, bg, kw.get("g", 9.81), np.array([t]))[0]
    return {"dp_x": dp[0], "dp_y": dp[1], "e2": dp[0] ** 2 + dp[1] ** 2}[which]


# (equation, monomial, printed coefficient, derived coefficient): every discrepancy the
# audit lists, under the package's convention and under the paper's NED-like reading,
# pinned one by one.
EXPECTED = {
    "z_up": [
        ("eq:phi/dp_x", "g*b_gy*t^3", "-1/6", "1/6"),
        ("eq:phi/dp_x", "b_ay*b_gz*t^3", "1/6", "-1/6"),
        ("eq:phi/dp_x", "b_az*b_gy*t^3", "-1/6", "1/6"),
        ("eq:phi/dp_y", "g*b_gx*t^3", "1/6", "-1/6"),
        ("eq:phi/dp_y", "b_az*b_gx*t^3", "1/6", "-1/6"),
        ("eq:error-3d", "g*dv_x*b_gy*t^4", "-1/3", "1/3"),
        ("eq:error-3d", "dv_x*b_az*b_gy*t^4", "-1/3", "1/3"),
        ("eq:error-3d", "g*b_ax*b_gy*t^5", "-1/6", "1/6"),
        ("eq:error-3d", "b_ax*b_az*b_gy*t^5", "-1/6", "1/6"),
    ],
    "z_down": [
        ("eq:phi/dp_x", "b_ay*b_gz*t^3", "1/6", "-1/6"),
        ("eq:phi/dp_x", "b_az*b_gy*t^3", "-1/6", "1/6"),
        ("eq:phi/dp_y", "b_az*b_gx*t^3", "1/6", "-1/6"),
        ("eq:error-3d", "g*dv_y*b_gx*t^4", "-1/3", "1/3"),
        ("eq:error-3d", "dv_x*b_az*b_gy*t^4", "-1/3", "1/3"),
        ("eq:error-3d", "g*b_ay*b_gx*t^5", "-1/6", "1/6"),
        ("eq:error-3d", "b_ax*b_az*b_gy*t^5", "-1/6", "1/6"),
        ("eq:error-3d", "g*b_az*b_gx^2*t^6", "1/18", "-1/18"),
        ("eq:error-3d", "g*b_az*b_gy^2*t^6", "1/18", "-1/18"),
    ],
}
PINS = [(c, *e) for c, lst in EXPECTED.items() for e in lst]


@pytest.mark.parametrize("conv", list(EXPECTED))
def test_audit_lists_exactly_the_pinned_discrepancies(conv):
    got = [(lab, tc.monomial, tc.printed, tc.derived[conv]) for lab, tc in S.audit("z_up").discrepancies(conv)]
    assert sorted(got) == sorted(EXPECTED[conv])


@pytest.mark.parametrize("conv, label, monomial, printed, derived", PINS,
                         ids=[f"{p[0]}:{p[1]}:{p[2]}" for p in PINS])
def test_each_discrepancy_against_the_ode(conv, label, monomial, printed, derived):
    """The derived coefficient comes out of the numerical ODE; the printed one does not."""
    c = S.convention(conv)
    t = 3.0
    factors = monomial.split("*")
    power = int(factors[-1].split("^")[1])
    powers = {}
    for fac in factors[:-1]:
        if fac != "g":
            name, _, e = fac.partition("^")
            powers[name] = int(e or 1)
    vals = {"dv_x": 0.07, "dv_y": 0.05, "b_ax": 0.3, "b_ay": 0.2, "b_az": 0.4, "b_gx": 0.02, "b_gy": 0.03,
            "b_gz": 0.04}
    which = {"eq:phi/dp_x": "dp_x", "eq:phi/dp_y": "dp_y", "eq:error-3d": "e2"}[label]
    # sign flips of the odd-power variables isolate the monomial (a b_az flip removes
    # the part without b_az); g is a constant factor
    coef = polarize(lambda kw: ode_value(c, which, t, **kw), {n: vals[n] for n in powers}, powers)
    g_power = factors.count("g")
    coef /= t**power * 9.81**g_power
    # 1e-7: polarization of an ODE solved to rtol 1e-13 with O(0.01)-sized terms
    assert coef == pytest.approx(float(sp.Rational(derived)), abs=1e-7)
    assert float(sp.Rational(printed)) != pytest.approx(coef, abs=1e-3)
    # and the printed coefficient really is what the paper prints
    s = S.symbols()
    gens = (s.g, *s.dv, *s.ba, *s.bg, s.t)
    pc = sp.Poly(S.paper_equations()[label], *gens)
    mono = sp.Poly(sp.sympify(monomial.replace("^", "**"), locals={str(x): x for x in gens}), *gens).monoms()[0]
    assert pc.coeff_monomial(mono) == sp.Rational(printed)


def test_no_convention_explains_the_bgz_cross_terms_or_e3d():
    a = S.audit()
    assert a.equation("eq:phi/dp_y").full_match == ()
    assert a.equation("eq:error-3d").full_match == ()
    # printed dp_x is reproduced only by the non-physical sign pairs (k = +1)
    assert a.equation("eq:phi/dp_x").full_match
    assert all(not S.convention(n).physical for n in a.equation("eq:phi/dp_x").full_match)
    notes = {k: ok for k, ok, _ in a.notes}
    assert notes["bgz-cross-signs"] and not notes["e3d-vs-printed-dp"] and notes["e2d-drops-baz"]
    assert notes["t4-magnitude"] and notes["2d-not-always-smaller"]


def test_e2d_is_printed_correctly_under_every_convention():
    assert len(S.audit().equation("eq:error-2d").full_match) == len(S.AUDIT_CONVENTIONS)


def test_printed_e3d_is_not_the_square_of_printed_dp():
    s = S.symbols()
    pe = S.paper_equations()
    sq = sp.expand((pe["eq:phi/dp_x"] ** 2 + pe["eq:phi/dp_y"] ** 2).subs(s.bg[2], 0))
    diff = sp.expand(sq - pe["eq:error-3d"])
    # the difference is exactly the two sign-flipped cross terms
    alpha = s.g + s.ba[2]
    dvy, bgx, bay = s.dv[1], s.bg[0], s.ba[1]
    assert sp.expand(diff - (sp.Rational(2, 3) * alpha * dvy * bgx * s.t**4
                             + sp.Rational(1, 3) * alpha * bay * bgx * s.t**5)) == 0


def test_audit_markdown_lists_every_discrepancy():
    from morpi_filters.report.assessment import audit_page

    r = S.audit()
    md = audit_page(r, S.dropped_bgz_terms(r.reference), [(c.name, c.physical) for c in S.AUDIT_CONVENTIONS])
    for _, lab, mono, *_ in PINS:
        assert f"| {lab} | `{mono}` |" in md


def test_time_varying_block_form_matches_numerical_integration():
    """C(t) turning about z and f(t) oscillating: the block integrals, evaluated by
    sympy, equal the solution of dPhi/dt = F(t) Phi integrated by DOP853."""
    s = S.symbols()
    t = s.t
    w = sp.Rational(3, 10)
    C = sp.Matrix([[sp.cos(w * t), -sp.sin(w * t), 0], [sp.sin(w * t), sp.cos(w * t), 0], [0, 0, 1]])
    f = sp.Matrix([sp.cos(2 * t) / 2, sp.Rational(1, 5), sp.Rational(981, 100)])
    for conv in (S.Convention("z_up"), S.Convention("z_up", 1, -1)):
        Phi = sp.lambdify(t, S.phi_block_form(conv, C=C, f=f).subs(s.t0, 0), "numpy")
        Fn = sp.lambdify(t, S.system_matrix_symbols(conv, C=C, f=f), "numpy")
        sol = solve_ivp(lambda tt, y: (np.asarray(Fn(tt), float) @ y.reshape(15, 15)).ravel(), (0, 4.0),
                        np.eye(15).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)  # solver tolerances of the reference transition matrix
        ref = sol.y[:, -1].reshape(15, 15)
        got = np.asarray(Phi(4.0), float)
        # 1e-10: DOP853 at rtol 1e-12 over 4 s; the closed form is exact
        assert np.linalg.norm(got - ref) / np.linalg.norm(ref) < 1e-10


@pytest.mark.parametrize("conv", S.AUDIT_CONVENTIONS, ids=lambda c: c.name)
def test_position_error_is_phi_applied_to_the_initial_state(conv):
    """position_error (from the series Phi) equals the full block-integral Phi times dx(0)."""
    s = S.symbols()
    f = sp.Matrix([s.ba[0], s.ba[1], conv.gravity_sign * s.g + s.ba[2]])
    Phi = S.phi_block_form(conv, C=sp.eye(3), f=f).subs(s.t0, 0)
    x0 = sp.Matrix([0, 0, 0, *s.dv, 0, 0, 0, *s.ba, *s.bg])
    dp = (Phi * x0)[0:3, :]
    assert sp.expand(dp - S.position_error(conv, "INS-3D", True)).is_zero_matrix
