"""The ``solver_sensitive`` tests again under other numerical kernels (``make test-kernels``).

A solver's path (IPOPT's iterates, a QP's pivots, a recursion's round-off, a particle filter's
resampling) changes with the CPU's instruction set and the BLAS kernels selected, so a test
that passes on one machine may fail on another. This script imitates other machines on this
one: each setting re-runs the tests marked ``solver_sensitive`` with

- ``OPENBLAS_CORETYPE``: the OpenBLAS kernels of an older CPU (numpy's and scipy's OpenBLAS
  are built for every x86-64 core and pick one at load time; set only on x86-64, and only to
  a core whose instructions this CPU has);
- ``NPY_DISABLE_CPU_FEATURES``: numpy's SIMD loops of some instruction sets switched off,
  computed here from the features numpy was built to dispatch *and* this CPU has (numpy
  refuses to disable any other);
- ``OPENBLAS_NUM_THREADS``: one BLAS thread against several (another summation order);
- ``GLIBC_TUNABLES``: the C library's elementary functions (``exp``, ``sin``, ``cos``,
  ``atan2``, ``pow``, which casadi, the compiled closed form and numpy's scalar loops call)
  without their FMA/AVX2 variants, whose last bits differ (glibc on x86-64 only).

Usage: ``python tests/kernels.py [--dry-run] [pytest arguments]``; the exit status is
non-zero if any setting fails. Each setting's environment and the BLAS kernels actually
loaded (threadpoolctl) are printed before its run.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import time


def _numpy_features() -> tuple[list[str], dict[str, bool]]:
    """numpy's dispatched features (in build order) and the features this CPU has."""
    try:
        from numpy._core import _multiarray_umath as um  # numpy >= 2
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as um  # type: ignore[no-redef]
    return list(um.__cpu_dispatch__), dict(um.__cpu_features__)


def _x86_64() -> bool:
    return platform.machine().lower() in ("x86_64", "amd64")


def settings() -> list[tuple[str, dict[str, str]]]:
    """The kernel settings: (name, environment overrides), each unlike this machine's own.

    1. ``older-cpu``: numpy at its baseline (every dispatched SIMD extension off), OpenBLAS
       on Sandy Bridge kernels (AVX, no FMA), one BLAS thread, glibc's libm without FMA;
    2. ``no-avx512``: numpy without its AVX-512 loops, OpenBLAS on Haswell kernels (AVX2 and
       FMA, no AVX-512), two BLAS threads;
    3. ``haswell-blas``: OpenBLAS on Haswell kernels alone, two BLAS threads (on an AVX-512
       machine this alone made an IPOPT re-plan stop at its iteration limit that converged
       with the machine's own kernels, and with those of 1 and 2).

    A setting that would change nothing here (no AVX-512 to switch off, no x86-64 kernels to
    choose) is left out, as is one equal to another.
    """
    dispatch, has = _numpy_features()
    present = [f for f in dispatch if has.get(f)]
    avx512 = [f for f in present if "AVX512" in f or f == "X86_V4"]
    older = {"NPY_DISABLE_CPU_FEATURES": " ".join(present), "OPENBLAS_NUM_THREADS": "1"}
    newer = {"NPY_DISABLE_CPU_FEATURES": " ".join(avx512), "OPENBLAS_NUM_THREADS": "2"}
    blas = {"OPENBLAS_NUM_THREADS": "2"}
    if _x86_64():
        older["OPENBLAS_CORETYPE"] = "SandyBridge" if has.get("AVX") else "Nehalem"
        if platform.libc_ver()[0] == "glibc":
            older["GLIBC_TUNABLES"] = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F"
        if has.get("AVX2") and has.get("FMA3"):
            newer["OPENBLAS_CORETYPE"] = blas["OPENBLAS_CORETYPE"] = "Haswell"
    out: list[tuple[str, dict[str, str]]] = []
    for name, env in (("older-cpu", older), ("no-avx512", newer), ("haswell-blas", blas)):
        env = {k: v for k, v in env.items() if v}
        if set(env) - {"OPENBLAS_NUM_THREADS"} and all(env != e for _, e in out):
            out.append((name, env))
    return out


#: A fingerprint of the C library's elementary functions (Python's math calls them).
_LIBM = ("import hashlib, math, struct\n"
         "v = [f(0.001 + i * 7.3e-4) for f in (math.exp, math.sin, math.atan) "
         "for i in range(3000)]\n"
         "libm = hashlib.sha256(struct.pack(f'{len(v)}d', *v)).hexdigest()[:12]\n")


def _probe(env: dict[str, str]) -> None:
    """Print the BLAS kernels, numpy features and libm fingerprint a process gets."""
    code = (_LIBM + "print('    libm fingerprint (exp, sin, atan):', libm)\n"
            "import numpy, scipy.linalg, threadpoolctl\n"
            "try:\n"
            "    from numpy._core import _multiarray_umath as um\n"
            "except ImportError:\n"
            "    from numpy.core import _multiarray_umath as um\n"
            "on = [f for f in um.__cpu_dispatch__ if um.__cpu_features__.get(f)]\n"
            "print('    numpy dispatched SIMD on:', ' '.join(on) or '(baseline only)')\n"
            "for i in threadpoolctl.threadpool_info():\n"
            "    print('    ' + i['internal_api'], i.get('architecture'), i['num_threads'],\n"
            "          'thread(s)', i['filepath'].rsplit('/', 1)[-1])\n")
    subprocess.run([sys.executable, "-W", "error::ImportWarning", "-c", code], env=env,
                   check=True)


def main(argv: list[str]) -> int:
    dry = "--dry-run" in argv
    args = [a for a in argv if a != "--dry-run"]
    failed = []
    print("== kernels: this machine's own", flush=True)
    _probe(dict(os.environ))
    for name, overrides in settings():
        env = os.environ | overrides | {"MPLBACKEND": "Agg"}
        shown = " ".join(f"{k}={v!r}" for k, v in sorted(overrides.items()))
        print(f"== kernels {name}: {shown}", flush=True)
        _probe(env)
        if dry:
            continue
        t0 = time.perf_counter()
        rc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                             "-m", "solver_sensitive and not slow", *args], env=env).returncode
        print(f"== kernels {name}: exit {rc} in {time.perf_counter() - t0:.0f} s", flush=True)
        if rc:
            failed.append(name)
    if failed:
        print(f"== kernels: failed under {', '.join(failed)}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
