"""Tests of the gonio Python module on the real reference data (README.md "Test data").

The folder is the environment variable GONIO_TEST_DATA, else the build's default
(GONIO_TEST_DATA_DEFAULT, set by CTest: ../shared/data beside the checkout). Where it is absent
each test is skipped with a reason naming GONIO_TEST_DATA, and prints one line that
scripts/test counts, as the C++ tests do (tests/test_util.h).
"""
import csv
import math
import os
import unittest

import numpy as np

import gonio


def test_data(test):
    """The test data folder, or unittest.SkipTest naming GONIO_TEST_DATA when it is absent."""
    folder = os.environ.get("GONIO_TEST_DATA") or os.environ.get("GONIO_TEST_DATA_DEFAULT", "")
    present = os.path.isdir(folder)
    print("[gonio test data] %s %s %s" % (test.id(), "used" if present else "skipped", folder),
          flush=True)
    if not present:
        raise unittest.SkipTest("the real test data are absent: %s is not a folder; set "
                                "GONIO_TEST_DATA to the folder (README.md, \"Test data\")" % folder)
    return folder


def curet_sample(folder, sample):
    """One CURET sample in degrees: theta_i, theta_r, |phi_r - phi_i| folded to [0, 180]."""
    rows = [r for r in csv.DictReader(open(os.path.join(folder, "curet", "curet_subset.csv")))
            if r["sample"] == sample]
    ti = np.degrees([float(r["theta_i"]) for r in rows])
    tr = np.degrees([float(r["theta_r"]) for r in rows])
    dphi = np.array([float(r["phi_r"]) - float(r["phi_i"]) for r in rows])
    phi = np.degrees(np.abs(np.remainder(dphi + math.pi, 2 * math.pi) - math.pi))
    return ti, tr, phi, np.array([float(r["brdf"]) for r in rows])


class CuretTest(unittest.TestCase):
    def test_plaster_fits_a_rough_body_through_python(self):
        # CURET plaster (sample 10, 205 geometries, relative units): the same figures as
        # `gonio fit-table` (docs/curet.md: Oren-Nayar sigma 22.8 deg, rel_rms 0.049; Lambert
        # rel_rms 0.255), read here through numpy instead of the C++ table reader.
        ti, tr, phi, value = curet_sample(test_data(self), "10")
        self.assertEqual(len(value), 205)
        fit = gonio.fit_table(ti, tr, phi, value, models=["lambert", "oren-nayar"], relative=True)
        self.assertEqual(fit["selected"], "oren-nayar")
        by_model = {c["model"]: c for c in fit["candidates"]}
        on = by_model["oren-nayar"]
        self.assertAlmostEqual(math.degrees(on["params"]["sigma"]), 22.8, delta=0.5)
        self.assertLess(on["rel_rms"], 0.055)
        self.assertGreater(by_model["lambert"]["rel_rms"], 4 * on["rel_rms"])


if __name__ == "__main__":
    unittest.main()
