"""Dryden turbulence from Python (dronetwin.dryden_gusts, dryden_psd, dryden_scales): numpy
records with the Dryden variances, seeded, the spectra integrating to the variances, bad
arguments named."""

import numpy as np
import pytest

import dronetwin as dt


def test_gust_records_are_seeded_and_have_the_dryden_variances():
    scales = dt.dryden_scales(3.0, "severe")
    g = dt.dryden_gusts(3.0, 10.0, 0.02, 1 << 19, severity="severe", seed=4)
    assert g.shape == (1 << 19, 3) and g.dtype == np.float64
    np.testing.assert_array_equal(g[:1000], dt.dryden_gusts(3.0, 10.0, 0.02, 1000, severity="severe", seed=4))
    # 2.9 h: thousands of correlation times per component; within 10 % (about 5 sigma).
    np.testing.assert_allclose(g.var(axis=0), scales["sigma_m_s"] ** 2, rtol=0.1)


def test_spectra_integrate_to_the_variances():
    scales = dt.dryden_scales(10.0, wind_at_20ft_m_s=8.0)
    theta = (np.arange(100000) + 0.5) * (0.5 * np.pi / 100000)
    for k in range(3):
        scale = 5.0 / scales["length_m"][k]
        omega = scale * np.tan(theta)
        phi = dt.dryden_psd(10.0, 5.0, omega, wind_at_20ft_m_s=8.0)[:, k]
        total = np.sum(phi * scale / np.cos(theta) ** 2) * (0.5 * np.pi / 100000)
        assert total == pytest.approx(scales["sigma_m_s"][k] ** 2, rel=1e-5)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="severity: expected 'light', 'moderate' or 'severe', got 'stormy'"):
        dt.dryden_scales(3.0, "stormy")
    with pytest.raises(ValueError, match="dt_s: expected > 0, got 0"):
        dt.dryden_gusts(3.0, 5.0, 0.0, 10)
    with pytest.raises(ValueError, match="wind_at_20ft_m_s: expected a finite number >= 0, got -1"):
        dt.dryden_scales(3.0, wind_at_20ft_m_s=-1.0)
