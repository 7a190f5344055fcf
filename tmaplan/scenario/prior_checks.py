"""The rules of a scenario's prior (:class:`tmaplan.scenario.Prior`) across its fields.

Called by :func:`tmaplan.scenario.checks.check`; every rule raises
:class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received value:

* A prior states its velocity and never takes the truth silently (a mean left out is the
  truth only with ``centred_on_truth = true``); at most :data:`MAX_PRIOR_SAMPLES` samples.
* A key that the prior's kind, distributions or course mode do not read is refused unless it
  keeps its default (:func:`ignored_prior_keys`).
* Every std the prior samples is > 0 (:func:`zero_prior_stds`: a zero std leaves the prior
  without a density), but the point masses of a normal range or speed, whose mean must then
  lie in the support; a normal range or speed with std > 0 keeps at least
  :data:`MIN_TRUNCATED_MASS` of its mass within its truncation
  (:func:`check_truncated_normal`).

These read the prior's own numbers only; :mod:`tmaplan.models.prior` samples the prior and
uses :func:`check_truncated_normal` and :func:`zero_prior_stds` (the one list of the prior's
zero stds) as well.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from scipy.special import log_ndtr

from tmaplan.errors import ScenarioError

__all__ = ["MAX_PRIOR_SAMPLES", "MIN_TRUNCATED_MASS", "check_prior", "check_truncated_normal",
           "ignored_prior_keys", "truncated_normal_log_mass", "zero_prior_stds"]

#: least probability mass that a normal range or speed prior must keep within its truncation
#: [min, max]: with less, every draw sits at the nearer bound (a degenerate prior)
MIN_TRUNCATED_MASS = 1e-6
#: most prior samples a scenario may ask for (4 floats each: 320 MB)
MAX_PRIOR_SAMPLES = 10_000_000


def _err(field: str, expected: str, received: Any, source: str | None) -> ScenarioError:
    return ScenarioError(field, expected, received, source=source)


def check_prior(p: Any, target_model: str, source: str | None) -> None:
    """Validate prior ``p`` of a scenario whose target model is ``target_model``; raise
    ScenarioError on the first violated rule (module notes)."""
    _check_prior(p, source)
    _check_prior_keys(p, source)
    if p.kind == "gaussian":
        if p.std is None:
            raise _err("prior.std", "[σ_x, σ_y, σ_vx, σ_vy] for a gaussian prior", None,
                       source)
    else:
        if p.range_distribution == "normal" and p.range_std is None:
            raise _err("prior.range_std", "a range std for range_distribution 'normal'",
                       None, source)
        if p.range_distribution in ("uniform", "log-uniform"):
            if p.range_max is None:
                raise _err("prior.range_max", f"a value for '{p.range_distribution}'",
                           None, source)
            if p.range_distribution == "log-uniform" and p.range_min <= 0:
                raise _err("prior.range_min", "> 0 for 'log-uniform'", p.range_min, source)
        if p.range_max is not None and p.range_max <= p.range_min:
            raise _err("prior.range_max", f"> range_min = {p.range_min} m", p.range_max,
                       source)
        if p.velocity_distribution == "speed-course":
            if p.speed_distribution == "uniform" and p.speed_max is None:
                raise _err("prior.speed_max", "a value for speed_distribution 'uniform'",
                           None, source)
            if p.speed_max is not None and p.speed_max <= p.speed_min:
                raise _err("prior.speed_max", f"> speed_min = {p.speed_min} m/s",
                           p.speed_max, source)
            if p.course_mode == "given" and p.course_mean is None:
                raise _err("prior.course_mean", "a value for course_mode 'given'", None,
                           source)
        _check_point_means(p, source)
        if target_model == "constant-turn" and (p.range_mean is None or p.bearing_mean is None):
            raise _err("prior", "explicit means for a constant-turn target", None, source)
    _check_prior_spreads(p, source)


def _check_prior(p: Any, source: str | None) -> None:
    """A prior states its velocity and never takes the truth silently."""
    if not 5 <= p.samples <= MAX_PRIOR_SAMPLES:  # 5: a belief's fewest samples (moments)
        raise _err("prior.samples", f"between 5 and {MAX_PRIOR_SAMPLES}", p.samples, source)
    if p.kind == "polar":
        if p.velocity_distribution == "normal" and not p.velocity_std > 0:
            raise _err("prior.velocity_std", "a velocity prior: velocity_mean = [v_x, v_y] with "
                       "velocity_std > 0 per axis (e.g. velocity_mean = [0, 0], velocity_std = "
                       "\"7.5 kn\"), or velocity_distribution = \"speed-course\" with "
                       "speed_distribution = \"uniform\", speed_max (e.g. \"15 kn\") and "
                       "course_mode = \"uniform\"", p.velocity_std, source)
        if p.velocity_distribution == "speed-course" and p.course_mode is None:
            raise _err("prior.course_mode", "a course prior for velocity_distribution "
                       "'speed-course': \"uniform\", \"given\" (with course_mean and "
                       "course_std), \"reciprocal-bearing\", or \"true\" (the true course, "
                       "on purpose)", None, source)
    means = p.truth_means  # course_mode "true" is itself the explicit choice
    if p.centred_on_truth and not means:
        raise _err("prior.centred_on_truth", "false (or the key left out): every mean of this "
                   "prior is given, so nothing would be centred on the truth", "true", source)
    if p.centred_on_truth:
        return
    for name in means:
        raise _err(f"prior.{name}", f"a value: without '{name}' the prior would take the "
                   "target's true initial value; add the key, or set prior.centred_on_truth "
                   "= true to centre the prior on the truth on purpose (as the papers' bounds "
                   "do)", None, source)


def ignored_prior_keys(p: Any) -> dict[str, str]:
    """Fields of prior ``p`` that :func:`tmaplan.models.prior.sample_prior` does not read (nor
    the consistency monitor, which bounds its rejuvenation by ``range_min``, ``range_max``
    and ``speed_max`` of any prior), each with the setting that makes it unused (``"kind"``,
    ``"range_distribution"``, …)."""
    gaussian = ("mean", "std")
    common = ("kind", "samples", "seed", "centred_on_truth")
    polar = tuple(f.name for f in dataclasses.fields(p) if f.name not in gaussian + common)
    speed_course = ("speed_distribution", "speed_mean", "speed_std", "speed_min", "speed_max",
                    "course_mode", "course_mean", "course_std")
    rules = (  # (selector, it makes the names unused, names); the first rule names the setting
        ("kind", p.kind == "gaussian", polar),
        ("kind", p.kind == "polar", gaussian),
        ("range_distribution", p.range_distribution != "normal", ("range_mean", "range_std")),
        ("velocity_distribution", p.velocity_distribution == "normal", speed_course),
        ("velocity_distribution", p.velocity_distribution == "speed-course",
         ("velocity_mean", "velocity_std")),
        ("speed_distribution", p.speed_distribution == "uniform", ("speed_mean", "speed_std")),
        ("course_mode", p.course_mode != "given", ("course_mean",)),
        ("course_mode", p.course_mode == "uniform", ("course_std",)),
    )
    # the support bounds of the consistency monitor's rejuvenation, whatever the sampling
    # (tmaplan.estimators.consistency): never unused
    monitor = ("range_min", "range_max", "speed_max")
    out: dict[str, str] = {}
    for selector, unused, names in rules:
        for name in names if unused else ():
            if name not in monitor:
                out.setdefault(name, selector)
    return out


def _check_prior_keys(p: Any, source: str | None) -> None:
    """Refuse a prior key that the chosen kind, distribution or course mode ignores, unless it
    keeps its default (:func:`tmaplan.scenario.dump` writes defaults, so files round-trip)."""
    ignored = ignored_prior_keys(p)
    for f in dataclasses.fields(p):
        value = getattr(p, f.name)
        if f.name in ignored and value != f.default:
            selector = ignored[f.name]
            raise _err(f"prior.{f.name}", f"not set with prior.{selector} = "
                       f"{getattr(p, selector)!r} (it is ignored there)", value, source)


def _check_point_means(p: Any, source: str | None) -> None:
    """A normal range or speed prior with std 0 is a point mass at its mean: a given mean must
    lie in the support; with std > 0 the support must keep a non-negligible mass of the
    normal (:func:`check_truncated_normal`). :mod:`tmaplan.models.prior` refuses a
    truth-centred mean for either when it samples."""
    parts = [("range", p.range_mean, p.range_std, p.range_min, p.range_max, "m")] \
        if p.range_distribution == "normal" else []
    if p.velocity_distribution == "speed-course" and p.speed_distribution == "normal":
        parts.append(("speed", p.speed_mean, p.speed_std, p.speed_min, p.speed_max, "m/s"))
    for name, mean, std, lo, hi, unit in parts:
        top = math.inf if hi is None else hi
        if mean is not None and not std and not lo <= mean <= top:
            raise _err(f"prior.{name}_mean", f"a value within [{lo}, {top}] {unit} (prior."
                       f"{name}_std is 0: every sample is the mean)", mean, source)
        if mean is not None and std:
            check_truncated_normal(name, mean, std, lo, top, unit, source)


def _check_prior_spreads(p: Any, source: str | None) -> None:
    """Every std the prior samples is > 0 but the point masses a normal range or speed allows
    (``range_std``, ``speed_std``: :func:`_check_point_means`) and the course about the
    reciprocal bearing (it follows the bearing's spread). Any other zero std leaves the prior
    without a density: its covariance is singular, so the bounds' prior information (its
    inverse) does not exist (NaN or "singular matrix" at step 0)."""
    why = ("a zero std leaves the prior without a density, and the bounds without its "
           "information, the inverse of the prior covariance")
    zero = zero_prior_stds(p, point_masses=False)  # the one list of the prior's zero stds
    if not zero:
        return
    field = zero[0]
    if field.startswith("prior.std["):
        raise _err(field, f"> 0 ({why})", 0.0, source)
    if field == "prior.bearing_std":
        raise _err(field, f"> 0 for a polar prior, e.g. \"2 deg\" ({why}; 0 is the default "
                   "when the key is left out)", p.bearing_std, source)
    if field == "prior.course_std":
        raise _err(field, f"> 0 with prior.course_mode = {p.course_mode!r} ({why}; 0 is the "
                   "default when the key is left out)", p.course_std, source)
    raise _err(field, f"> 0 ({why})", getattr(p, field.removeprefix("prior.")), source)


def truncated_normal_log_mass(mean: float, std: float, lo: float, hi: float) -> float:
    """Natural log of the probability mass of N(mean, std²) within [lo, hi] (``hi`` may be
    inf; ``std`` > 0), accurate far in either tail (``scipy.special.log_ndtr``): -inf only
    when the mass underflows even as a logarithm."""
    a, b = (lo - mean) / std, (hi - mean) / std
    if a > 0:  # both bounds in the upper tail: the mirror image lies in the accurate lower one
        a, b = -b, -a
    la, lb = float(log_ndtr(a)), float(log_ndtr(b))
    return lb + math.log1p(-math.exp(la - lb)) if la < lb else -math.inf


def check_truncated_normal(name: str, mean: float, std: float, lo: float, hi: float,
                           unit: str, source: str | None, *, truth: bool = False) -> None:
    """Refuse a normal ``name`` prior ("range" or "speed", ``std`` > 0) whose truncation to
    [lo, hi] keeps less than :data:`MIN_TRUNCATED_MASS` of N(mean, std²) (every draw would
    sit at the nearer bound), naming ``prior.<name>_mean``, the interval and the mass;
    ``truth``: the mean is the target's true value (``centred_on_truth``)."""
    if not std > 0:
        return
    log_mass = truncated_normal_log_mass(mean, std, lo, hi)
    if log_mass >= math.log(MIN_TRUNCATED_MASS):
        return
    mass = math.exp(log_mass)
    kept = f"{mass:.3g}" if mass > 0 else f"10^{log_mass / math.log(10):.4g}"
    raise ScenarioError(
        f"prior.{name}_mean", f"a value leaving at least {MIN_TRUNCATED_MASS:g} of "
        f"N({name}_mean, {name}_std²) within [{name}_min, {name}_max] = [{lo:g}, {hi:g}] "
        f"{unit}: with {name}_std = {std:g} {unit} it keeps {kept} of its mass (every draw "
        "would sit at the nearer bound)" + (f"; the key is left out, so the mean is the "
                                            f"target's true initial {name}" if truth else ""),
        mean, source=source)


def zero_prior_stds(prior: Any, *, point_masses: bool = True) -> tuple[str, ...]:
    """The std fields of ``prior`` that :func:`tmaplan.models.prior.sample_prior` uses and
    that are zero.

    Each makes the prior degenerate (no density in that component): the prior information
    ``J0 = P0⁻¹`` of the closed-form bound (brehard2005, eq. 56) does not exist.

    Parameters
    ----------
    prior : Prior
    point_masses : bool
        Include the zeros a scenario may keep (False: the scenario's load check, which
        refuses the others): ``range_std`` / ``speed_std`` of a normal range or speed (a
        point mass at the mean) and ``course_std`` with ``course_mode = "reciprocal-bearing"``
        (the course follows the bearing's spread). The closed-form bound refuses them too.

    Returns
    -------
    tuple of str
        Dotted field names (``"prior.bearing_std"``, ``"prior.std[2]"``, …) in file order;
        empty if every sampled component has a positive std.
    """
    p = prior
    if p.kind == "gaussian":
        return tuple(f"prior.std[{i}]" for i, v in enumerate(p.std or ()) if v == 0)
    out = []
    if p.bearing_std == 0:
        out.append("prior.bearing_std")
    if point_masses and p.range_distribution == "normal" and not p.range_std:
        out.append("prior.range_std")
    if p.velocity_distribution == "normal":
        if p.velocity_std == 0:
            out.append("prior.velocity_std")
    else:
        if point_masses and p.speed_distribution == "normal" and p.speed_std == 0:
            out.append("prior.speed_std")
        kept = ("uniform",) if point_masses else ("uniform", "reciprocal-bearing")
        if p.course_mode not in kept and p.course_std == 0:
            out.append("prior.course_std")
    return tuple(out)
