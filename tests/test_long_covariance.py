"""One hour at 100 Hz (360,000 steps): covariances kept by stride, symmetric and PSD, with and without updates."""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import units
from morpi_filters.error_model import discretize, noise_coupling, noise_density, paper_trajectory, system_matrix
from morpi_filters.errors import MorpiError
from morpi_filters.eskf import (
    StepModel, augment, augment_covariance, initial_covariance, propagate_covariance, run_filter, step_update,
)

G_MPS2 = 9.81
SV, SA, SG = np.array([0.05, 0.08, 0.02]), np.array([0.3, 0.2, 0.1]), np.array([0.01, 0.02, 0.005])
DT, HOUR = 0.01, 360_000
MINUTE = 6000
EPS = np.finfo(float).eps


def _model(noise):
    C, f = paper_trajectory(G_MPS2)
    Q = noise_density(units.MPU6500) * (1.0 if noise else 0.0)
    return discretize(system_matrix(C, f), noise_coupling(C), Q, DT)


def _psd_bar(n, k):
    """Worst-case rounding of n steps of ``Phi P Phi^T + Q``: each step rounds a sum of 2k products (eps each)."""
    return n * 2 * k * EPS


def _assert_symmetric_psd(P, bar):
    """Exactly symmetric; PSD on the correlation scale (invariant to the 1e-6..1e17 spread of the variances)."""
    assert np.array_equal(P, np.swapaxes(P, -1, -2))
    for Pk in P.reshape(-1, *P.shape[-2:]):
        d = np.sqrt(np.diag(Pk))
        assert (np.diag(Pk) >= 0).all()
        nz = d > 0
        assert not np.any(Pk[~nz]), "a zero variance with a non-zero covariance"
        corr = Pk[np.ix_(nz, nz)] / np.outer(d[nz], d[nz])
        assert np.linalg.eigvalsh(corr).min() >= -bar


def test_keep_P_stride_keeps_every_sth_epoch():
    Phi, Qd = _model(True)
    P0 = initial_covariance(SV, SA, SG, dp0=0.01, eps0=1e-3)
    n = 1000
    t = np.arange(n + 1) * DT
    every = run_filter(Phi, Qd, P0, t, keep_P=True)
    strided = run_filter(Phi, Qd, P0, t, keep_P=100)
    np.testing.assert_array_equal(strided.P_index, np.arange(0, n + 1, 100))
    # the same recursion, kept at fewer epochs: identical numbers
    np.testing.assert_array_equal(strided.P, every.P[::100])
    assert run_filter(Phi, Qd, P0, t).P is None
    with pytest.raises(MorpiError, match="keep_P"):
        run_filter(Phi, Qd, P0, t, keep_P=0)


def test_one_hour_unaided_matches_the_closed_form_and_stays_symmetric_psd():
    Phi, Qd = _model(False)
    t = np.arange(HOUR + 1) * DT
    r = run_filter(Phi, Qd, initial_covariance(SV, SA, SG), t, keep_P=MINUTE)
    assert r.P.shape == (HOUR // MINUTE + 1, 15, 15)
    _assert_symmetric_psd(r.P, _psd_bar(HOUR, 15))
    _assert_symmetric_psd(r.P_end, _psd_bar(HOUR, 15))
    # Noise off: the horizontal variance is the z-up polynomial
    # (dv t + ba t^2/2 + g bg t^3/6 per axis), up to rounding of 360,000 steps
    # (360,000 * 2.2e-16 = 8e-11 per chain of products): bar 1e-9.
    want = ((SV[0] ** 2 + SV[1] ** 2) * t ** 2 + (SA[0] ** 2 + SA[1] ** 2) * t ** 4 / 4
            + G_MPS2 ** 2 * (SG[0] ** 2 + SG[1] ** 2) * t ** 6 / 36)
    got = r.horizontal_sigma ** 2
    assert np.max(np.abs(got[1:] / want[1:] - 1)) < 1e-9


def test_one_hour_with_noise_and_updates_stays_symmetric_psd():
    Phi, Qd = _model(True)
    P0 = initial_covariance(SV, SA, SG, dp0=0.01, eps0=1e-3)
    t = np.arange(HOUR + 1) * DT
    unaided = run_filter(Phi, Qd, P0, t, keep_P=MINUTE)
    _assert_symmetric_psd(unaided.P, _psd_bar(HOUR, 15))
    # the closed form of the same recursion (powers of Phi by doubling, another
    # order of operations) at the same epochs: rounding of 360,000 steps, bar 1e-9
    closed = propagate_covariance(Phi, Qd, P0, HOUR, stride=MINUTE)
    scale = np.abs(unaided.P).max(axis=(1, 2))[:, None, None]
    assert np.max(np.abs(closed - unaided.P) / scale) < 1e-9
    _assert_symmetric_psd(closed, _psd_bar(HOUR, 15))

    model = StepModel()
    Phi_a, Qd_a = augment(Phi, Qd, model)
    meas = [step_update(i, 1.0, 0.0, model, 1.0) for i in range(100, HOUR + 1, 100)]  # one step per second
    aided = run_filter(Phi_a, Qd_a, augment_covariance(P0, model), t, meas, keep_P=MINUTE)
    _assert_symmetric_psd(aided.P, _psd_bar(HOUR, 22))
    assert np.isfinite(aided.sigma).all()
    # the steps (heading 0) bound the along-track error: far below INS alone after an hour
    assert aided.sigma[-1, 0] < 1e-3 * unaided.sigma[-1, 0]


def test_propagate_covariance_stride_equals_every_epoch_subsampled():
    Phi, Qd = _model(True)
    P0 = initial_covariance(SV, SA, SG, dp0=0.01, eps0=1e-3)
    full = propagate_covariance(Phi, Qd, P0, 2000)
    strided = propagate_covariance(Phi, Qd, P0, 2000, stride=100)
    assert strided.shape == (21, 15, 15)
    # two groupings of the same sums: rounding only (2000 steps * eps ~ 4e-13), bar 1e-11
    scale = np.abs(full[::100]).max(axis=(1, 2))[:, None, None]
    assert np.max(np.abs(strided - full[::100]) / scale) < 1e-11
    with pytest.raises(MorpiError, match="stride"):
        propagate_covariance(Phi, Qd, P0, 10, stride=0)
