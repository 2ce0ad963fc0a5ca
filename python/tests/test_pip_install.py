"""`pip install --no-build-isolation --no-index .` into a fresh virtual environment (with the
system's site packages, for numpy) installs a `gonio` module that imports from the environment,
not from the build tree: the install docs/python.md describes, checked as CI runs it.

The CMake build the test runs in is reused (GONIO_CMAKE_BUILD_DIR), so only the install is
timed here; `--no-index` makes any download attempt fail the test.
"""
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[2]


class PipInstall(unittest.TestCase):
    def test_install_into_a_venv_and_import(self):
        build_dir = os.environ["GONIO_CMAKE_BUILD_DIR"]
        with tempfile.TemporaryDirectory(prefix="gonio_pip_") as tmp:
            venv = Path(tmp) / "venv"
            subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                           check=True)
            python = venv / "bin" / "python"
            env = dict(os.environ)
            env.pop("PYTHONPATH", None)
            env["GONIO_CMAKE_BUILD_DIR"] = build_dir
            env["GONIO_PIP_BUILD_BASE"] = str(Path(tmp) / "build")
            env["GONIO_BUILD_JOBS"] = "1"
            install = subprocess.run(
                [str(python), "-m", "pip", "install", "--no-build-isolation", "--no-index",
                 str(SOURCE)], env=env, capture_output=True, text=True)
            self.assertEqual(install.returncode, 0, install.stdout + install.stderr)
            probe = subprocess.run(
                [str(python), "-c",
                 "import gonio, json; "
                 "print(json.dumps({'file': gonio.__file__, "
                 "'models': [m['name'] for m in gonio.models()], "
                 "'lambert': float(gonio.evaluate('lambert', {'albedo': 0.5}, 30.0, 40.0, 0.0))}))"],
                env=env, cwd=tmp, capture_output=True, text=True)
            self.assertEqual(probe.returncode, 0, probe.stderr)
            import json
            result = json.loads(probe.stdout)
            self.assertTrue(result["file"].startswith(str(venv)), result["file"])
            self.assertIn("oren-nayar", result["models"])
            # Lambert is albedo / pi whatever the angles.
            self.assertAlmostEqual(result["lambert"], 0.5 / 3.141592653589793, places=12)
            uninstall = subprocess.run([str(python), "-m", "pip", "uninstall", "-y", "gonio"],
                                       env=env, capture_output=True, text=True)
            self.assertEqual(uninstall.returncode, 0, uninstall.stderr)


if __name__ == "__main__":
    unittest.main()
