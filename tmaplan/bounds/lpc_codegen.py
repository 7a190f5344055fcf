"""Compiled (C) versions of the closed-form PCRB step functions, built once and cached.

:func:`compiled_step_functions`: casadi code generation of :func:`~tmaplan.bounds.lpc_terms.
step_functions`, compiled with the system C compiler; :func:`schedule_kernel`: the ``SX`` graph
of one generic Tichavský step (:func:`~tmaplan.bounds.lpc_terms.tichavsky_step`) emitted as a
straight-line C loop vectorised over ping schedules. Libraries are cached under
``$TMAPLAN_CACHE_DIR`` (else ``$XDG_CACHE_HOME/tmaplan`` or ``~/.cache/tmaplan``), keyed on the
source, flags, compiler and CPU; with no compiler (or ``TMAPLAN_JIT=0``) every function returns
``None`` and callers use the casadi VM / numpy reference paths.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
import warnings
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.bounds.lpc_terms import (
    aux_to_dterms,
    inverse_diagonal,
    pack_sym,
    step_functions,
    tichavsky_step,
    unpack_sym,
)

__all__ = [
    "JIT_FLAGS",
    "JIT_NATIVE",
    "cache_dir",
    "compile_c",
    "compiled_step_functions",
    "jit_enabled",
    "schedule_kernel",
]


# ---------------------------------------------------------------- compiled (JIT) versions
#: Compiler flags of the JIT. No -ffast-math and no FMA contraction (-ffp-contract=off): IEEE
#: results identical to the casadi VM and numpy; -fno-math-errno only lets ``sqrt`` vectorise.
JIT_FLAGS = ("-O3", "-fno-math-errno", "-ffp-contract=off", "-shared", "-fPIC")
#: Tried first (wider SIMD for the schedule kernel); the library is keyed on the CPU's flags.
JIT_NATIVE = ("-march=native",)


def jit_enabled() -> bool:
    """True if the C compiler path may be used (``$CC`` or gcc/cc on PATH; ``TMAPLAN_JIT=0``
    disables it)."""
    if os.environ.get("TMAPLAN_JIT", "1").strip().lower() in ("0", "false", "no", "off"):
        return False
    return _compiler() is not None


def _compiler() -> str | None:
    cc = os.environ.get("CC")
    return shutil.which(cc) if cc else (shutil.which("gcc") or shutil.which("cc"))


def cache_dir() -> Path:
    """``$TMAPLAN_CACHE_DIR``, else ``$XDG_CACHE_HOME/tmaplan``, else ``~/.cache/tmaplan``."""
    if os.environ.get("TMAPLAN_CACHE_DIR"):
        return Path(os.environ["TMAPLAN_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "tmaplan"


def compile_c(source: str, tag: str, *, native: bool = True) -> Path | None:
    """Compile C ``source`` into a shared library, cached by content under :func:`cache_dir`.

    The file name is ``<tag>_<sha256 of source, flags, compiler, machine>.so``; an existing
    library is reused (compiled once per machine). Writes go to a temporary file that is
    atomically renamed, so concurrent processes are safe. ``native``: try ``-march=native``
    first (wider SIMD; not used for the casadi step functions, where it changed round-off in
    cancelling D-term entries by ~1e-19 of their scale).

    Returns
    -------
    Path or None
        The library, or None (with a ``RuntimeWarning``) if there is no compiler, the JIT is
        disabled (``TMAPLAN_JIT=0``) or compilation fails; callers then use their pure
        casadi-VM / numpy fallback.
    """
    if not jit_enabled():
        return None
    cc = _compiler()
    variants = (JIT_FLAGS + JIT_NATIVE, JIT_FLAGS) if native else (JIT_FLAGS,)
    key = "\n".join([source, repr(variants), str(cc), platform.machine(), _cpu_flags()])
    digest = hashlib.sha256(key.encode()).hexdigest()[:20]
    out_dir = cache_dir() / "jit"
    lib = out_dir / f"{tag}_{digest}.so"
    if lib.exists():
        return lib
    error: Exception | None = None
    for flags in variants:  # -march=native is not universal
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
                src = Path(tmp) / f"{tag}.c"
                src.write_text(source)
                so = Path(tmp) / f"{tag}.so"
                subprocess.run([str(cc), *flags, "-o", str(so), str(src), "-lm"], check=True,
                               capture_output=True, timeout=300)
                os.replace(so, lib)
            return lib
        except (OSError, subprocess.SubprocessError) as exc:
            error = exc
    detail = getattr(error, "stderr", b"") or b""
    warnings.warn(f"tmaplan JIT: compiling {tag} failed ({error}; "
                  f"{detail.decode(errors='replace')[:300]}); using the uncompiled path",
                  RuntimeWarning, stacklevel=2)
    return None


@cache
def _cpu_flags() -> str:
    """The CPU feature line (Linux) so a library built with -march=native is not reused on a
    different CPU sharing the cache directory."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("flags", "Features")):
                return line
    except OSError:
        pass
    return platform.processor()


_COMPILED: dict[tuple[bytes, bytes], tuple[Any, Any] | None] = {}


def compiled_step_functions(A: np.ndarray, Q: np.ndarray) -> tuple[Any, Any] | None:
    """The :func:`step_functions` compiled to C (casadi code generation + gcc), or None.

    Same inputs, outputs and operation order as the ``SX`` functions (the generated C is
    casadi's translation of the very same expression graph), loaded with
    ``casadi.external``. Numeric use only: the planners' symbolic graphs keep using
    :func:`step_functions`. None when no compiler is available (see :func:`compile_c`).
    """
    key = (A.tobytes(), Q.tobytes())
    if key not in _COMPILED:
        import casadi as ca  # deferred: casadi is slow to import

        fns = step_functions(A, Q)
        cg = ca.CodeGenerator("tmaplan_lpc_steps.c", {"with_header": False})
        for f in fns:
            cg.add(f)
        lib = compile_c(cg.dump(), "lpc_steps", native=False)
        _COMPILED[key] = (None if lib is None
                          else tuple(ca.external(f.name(), str(lib)) for f in fns))  # type: ignore[assignment]
    return _COMPILED[key]


# ------------------------------------------ batched schedules: SX step -> SIMD C kernel
_KERNEL: dict[str, Any] = {}
_KERNEL_CHUNK = 128  # schedules per chunk: the (10, chunk) information state stays in L1


def _schedule_step_sx() -> Any:
    """``(j[10], aux[37], b, p) -> (j_next[10], [J_{t+1}⁻¹]_{ln r})``, from the generic code."""
    import casadi as ca  # deferred: casadi is slow to import

    j, a = ca.SX.sym("j", 10), ca.SX.sym("aux", 37)
    b, p = ca.SX.sym("b"), ca.SX.sym("p")
    d11, d12, d22 = aux_to_dterms([a[n] for n in range(37)])
    Jn, _ = tichavsky_step(unpack_sym([j[n] for n in range(10)]), d11, d12, d22, b, p)
    var, _ = inverse_diagonal(Jn)
    return ca.Function("lpc_schedule_step", [j, a, b, p], [ca.vertcat(*pack_sym(Jn)), var[1]])


def _emit_body(f: Any) -> list[str]:
    """Straight-line C of an SX Function's algorithm, one schedule ``s`` of a chunk.

    Inputs: ``J[nz*CH+s]`` (information state), ``a[nz]`` (aux of the step), ``b``, ``p``;
    outputs ``o<nz>`` (next state) and ``v`` (ln r variance). Raises NotImplementedError on
    an operation outside + − × ÷ (then the caller falls back to numpy).
    """
    import casadi as ca  # deferred: casadi is slow to import

    unary = {ca.OP_ASSIGN: "{0}", ca.OP_NEG: "-{0}", ca.OP_SQ: "{0}*{0}", ca.OP_INV: "1.0/{0}",
             ca.OP_TWICE: "2.0*{0}", ca.OP_SQRT: "sqrt({0})"}
    binary = {ca.OP_ADD: "+", ca.OP_SUB: "-", ca.OP_MUL: "*", ca.OP_DIV: "/"}
    src = ["J[{}*CH+s]", "a[{}]", "b", "p"]
    lines = [f"double {', '.join(f'w{i}' for i in range(f.sz_w()))};"]
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_INPUT:
            lines.append(f"w{outs[0]} = {src[ins[0]].format(ins[1])};")
        elif op == ca.OP_OUTPUT:
            lines.append(f"{'o' + str(outs[1]) if outs[0] == 0 else 'v'} = w{ins[0]};")
        elif op == ca.OP_CONST:
            lines.append(f"w{outs[0]} = {float(f.instruction_constant(k)).hex()};")
        elif op in binary:
            lines.append(f"w{outs[0]} = w{ins[0]} {binary[op]} w{ins[1]};")
        elif op in unary:
            lines.append(f"w{outs[0]} = {unary[op].format(f'w{ins[0]}')};")
        else:
            raise NotImplementedError(f"casadi operation {op} in the schedule kernel")
    return lines


def schedule_kernel() -> Any:
    """The Tichavský recursion over many ping schedules as a compiled C kernel (or None).

    The body is emitted instruction by instruction from the ``SX`` graph of
    :func:`tichavsky_step` + :func:`inverse_diagonal` (the one implementation), inside a loop
    over the schedules of a chunk that gcc vectorises (SIMD over schedules, structure-of-arrays
    state). Same operations in the same order as the numpy path, so results agree to round-off
    (in practice bit for bit). Signature (ctypes)::

        void lpc_schedules(long K, long S, const double *J0 /* (10, S) packed J_0 */,
            const double *aux /* (K, 37) */, const double *b, const double *pw,
            const double *er2 /* (K,) at t+1: bearing info, ping weight scale, E r² */,
            const double *u, long ustride /* u[s*ustride + t+1] */,
            double *acc /* (S,) += bound */, double *last /* (S,) */,
            double *out /* (S, ustride) per-step bound, or NULL */);
    """
    if "fn" in _KERNEL:
        return _KERNEL["fn"]
    fn = None
    try:
        body = _emit_body(_schedule_step_sx())
    except NotImplementedError:
        body = None
    lib = compile_c(_kernel_source(body), "lpc_schedules") if body else None
    if lib is not None:
        fn = ctypes.CDLL(str(lib)).lpc_schedules
        P, L = ctypes.c_void_p, ctypes.c_long
        fn.argtypes = [L, L, P, P, P, P, P, P, L, P, P, P]
        fn.restype = None
    _KERNEL["fn"] = fn
    return fn


def _kernel_source(body: list[str]) -> str:
    stores = "\n".join(f"        J[{n}*CH+s] = o{n};" for n in range(10))
    inner = "\n".join("        " + x for x in body)
    return f"""/* generated by tmaplan.bounds.lpc_terms.schedule_kernel: do not edit */
#include <math.h>
#include <stddef.h>
#define CH {_KERNEL_CHUNK}
void lpc_schedules(long K, long S, const double *J0, const double *aux, const double *bk,
                   const double *pw, const double *er2, const double *u, long ustride,
                   double *acc, double *last, double *out) {{
  double J[10*CH], pk[CH], rbk[CH], accc[CH];
  for (long c0 = 0; c0 < S; c0 += CH) {{
    const long n = S - c0 < CH ? S - c0 : CH;
    for (long e = 0; e < 10; ++e)
      for (long s = 0; s < n; ++s) J[e*CH + s] = J0[e*S + c0 + s];
    for (long s = 0; s < n; ++s) accc[s] = acc[c0 + s];
    for (long k = 0; k < K; ++k) {{
      const double *a = aux + 37*k;
      const double b = bk[k], pwk = pw[k], r2 = er2[k];
      const double *uk = u + c0*ustride + k + 1;
      for (long s = 0; s < n; ++s) pk[s] = uk[s*ustride] * pwk;
      /* SIMD over schedules: straight-line body, structure-of-arrays state */
      for (long s = 0; s < n; ++s) {{
        double o0, o1, o2, o3, o4, o5, o6, o7, o8, o9, v;
        const double p = pk[s];
{inner}
{stores}
        rbk[s] = sqrt(r2 * v);
        accc[s] += rbk[s];
      }}
      if (out)
        for (long s = 0; s < n; ++s) out[(c0 + s)*ustride + k + 1] = rbk[s];
    }}
    for (long s = 0; s < n; ++s) {{
      acc[c0 + s] = accc[s];
      if (K > 0) last[c0 + s] = rbk[s];
    }}
  }}
}}
"""
