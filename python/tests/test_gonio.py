"""Tests of the gonio Python module (run by CTest with PYTHONPATH=build/python).

Truth comes from outside the module: the Lambert and Oren-Nayar closed forms written out
here in numpy, and fit round trips on synthetic data with known parameters.
"""
import json
import math
import os
import tempfile
import unittest

import numpy as np

import gonio


def oren_nayar_qualitative(albedo, sigma, ti, tr, phi):
    """Oren & Nayar 1994 eq. 30 in numpy (degrees in)."""
    ti, tr, phi = np.radians(ti), np.radians(tr), np.radians(phi)
    s2 = sigma * sigma
    a = 1 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    alpha, beta = np.maximum(ti, tr), np.minimum(ti, tr)
    return albedo / math.pi * (a + b * np.maximum(0, np.cos(phi)) * np.sin(alpha) * np.tan(beta))


class ModelsTest(unittest.TestCase):
    def test_registry_lists_models_with_parameters(self):
        models = {m["name"]: m for m in gonio.models()}
        self.assertIn("oren-nayar", models)
        self.assertIn("oren-nayar-fujii", models)
        sigma = [p for p in models["oren-nayar"]["params"] if p["name"] == "sigma"][0]
        self.assertEqual(sigma["unit"], "rad")
        self.assertAlmostEqual(sigma["max"], 0.9)


class EvaluateTest(unittest.TestCase):
    def test_lambert_is_albedo_over_pi_and_keeps_shape(self):
        ti = np.linspace(0, 80, 12).reshape(3, 4)
        f = gonio.evaluate("lambert", {"albedo": 0.6}, ti, 30.0, 0.0)
        self.assertEqual(f.shape, (3, 4))
        np.testing.assert_allclose(f, 0.6 / math.pi, rtol=1e-15)

    def test_matches_numpy_closed_form(self):
        rng = np.random.default_rng(1)
        ti, tr, phi = rng.uniform(0, 85, 1000), rng.uniform(0, 85, 1000), rng.uniform(0, 180, 1000)
        f = gonio.evaluate("oren-nayar-qualitative", {"albedo": 0.7, "sigma": 0.4}, ti, tr, phi)
        np.testing.assert_allclose(f, oren_nayar_qualitative(0.7, 0.4, ti, tr, phi), rtol=1e-12)

    def test_invalid_angles_give_nan_and_bad_params_raise(self):
        f = gonio.evaluate("oren-nayar", {}, np.array([10.0, 95.0, 90.0]),
                           np.array([20.0, 20.0, 90.0]), 0.0)
        self.assertTrue(np.isfinite(f[0]))
        self.assertTrue(np.isnan(f[1]))  # theta_i outside [0, 90]
        self.assertTrue(np.isnan(f[2]))  # both at the horizon: f_r diverges
        with self.assertRaises(ValueError):
            gonio.evaluate("oren-nayar", {"sigma": 2.0}, 10.0, 10.0, 0.0)
        with self.assertRaises(ValueError):
            gonio.evaluate("oren-nayar", {"roughness": 0.1}, 10.0, 10.0, 0.0)
        with self.assertRaises(ValueError):
            gonio.evaluate("no-such-model", {}, 10.0, 10.0, 0.0)


class FitTest(unittest.TestCase):
    def test_fit_table_recovers_synthetic_parameters(self):
        g = np.meshgrid(np.arange(0, 81, 10.0), np.arange(0, 81, 10.0), np.arange(0, 181, 30.0))
        ti, tr, phi = (a.ravel() for a in g)
        value = gonio.evaluate("oren-nayar", {"albedo": 0.55, "sigma": 0.3}, ti, tr, phi)
        fit = gonio.fit_table(ti, tr, phi, value, models=["lambert", "oren-nayar"])
        self.assertEqual(fit["selected"], "oren-nayar")
        params = [c for c in fit["candidates"] if c["model"] == "oren-nayar"][0]["params"]
        self.assertAlmostEqual(params["albedo"], 0.55, delta=1e-4)
        self.assertAlmostEqual(params["sigma"], 0.3, delta=1e-4)

    def test_read_fit_and_export(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "fit.json")
            with open(path, "w") as f:
                json.dump({"selected": "oren-nayar", "candidates": [
                    {"model": "oren-nayar", "params": {"albedo": 0.5, "sigma": 0.35}}]}, f)
            m = gonio.read_fit(path)
            self.assertEqual(m["model"], "oren-nayar")
            self.assertEqual(m["params"], {"albedo": 0.5, "sigma": 0.35})
            self.assertEqual(m["channel_params"].shape, (3, 2))
            out = os.path.join(d, "m.xml")
            r = gonio.export("mitsuba", out, fit=path)
            self.assertTrue(r["exact"])
            self.assertAlmostEqual(r["shape"], 0.35)
            with open(out) as f:
                self.assertIn('value="%.6g"' % (math.sqrt(2) * 0.35), f.read())
            table = os.path.join(d, "t.csv")
            r = gonio.export("astm", table, model="oren-nayar", params={"sigma": 0.2})
            t = gonio.load_table(table)
            self.assertEqual(len(t["value"]), r["n_values"])
            np.testing.assert_allclose(
                t["value"], gonio.evaluate("oren-nayar", {"sigma": 0.2}, t["theta_i"],
                                           t["theta_r"], t["phi"]), rtol=1e-8)
            with self.assertRaises(ValueError):
                gonio.read_fit(os.path.join(d, "missing.json"))


if __name__ == "__main__":
    unittest.main()
