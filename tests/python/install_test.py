"""`cmake --install` installs the Python module (ctest: python.install;
docs/python.md): the build installed into a fresh prefix, then
`import feedid` with PYTHONPATH at the installed package's folder, in a
new interpreter, must load the installed copy (not the build's) and
identify. Exit 77 (ctest: skipped) where the module was not built.
"""
import os
import subprocess
import sys
import tempfile

BUILD = os.environ["FEEDID_BUILD_DIR"]
PACKAGE_DIR = os.environ["FEEDID_PYTHON_INSTALL_DIR"]  # relative to the prefix
if not os.path.exists(os.path.join(BUILD, "python", "feedid", "__init__.py")):
    print("skipped: the module was not built (FEEDID_PYTHON off)")
    sys.exit(77)

CHECK = """
import os, sys, numpy as np, feedid
assert os.path.realpath(feedid.__file__).startswith(os.path.realpath(sys.argv[1])), feedid.__file__
t = np.arange(0, 20, 0.001)
x = 0.1 * np.sin(2 * np.pi * 0.5 * t) + 0.05 * np.sin(2 * np.pi * 1.7 * t)
v = np.gradient(x, t)
a = np.gradient(v, t)
u = 2.0 * a + 10 * v + 3 * np.sign(v)
r = feedid.identify(t, x, u)
assert abs(r["m"] - 2.0) < 0.2, r["m"]
print("installed feedid at", feedid.__file__, "m", r["m"])
"""

with tempfile.TemporaryDirectory() as prefix:
    subprocess.run(["cmake", "--install", BUILD, "--prefix", prefix], check=True, stdout=subprocess.DEVNULL)
    installed = os.path.join(prefix, PACKAGE_DIR)
    env = dict(os.environ, PYTHONPATH=installed)
    done = subprocess.run([sys.executable, "-c", CHECK, installed], env=env, cwd=prefix)
    sys.exit(done.returncode)
