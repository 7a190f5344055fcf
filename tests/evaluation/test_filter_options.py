"""The closed loop's particle-filter kernel (:attr:`FilterOptions.kernel`): the compiled
kernels by default (issue 42's campaign throughput), the numpy kernels still callable and
flying the campaigns stored before the switch exactly as they were, each kernel under its own
campaign key."""

from __future__ import annotations

import dataclasses
import math

import pytest

from tmaplan.errors import ArgumentError
from tmaplan.estimators.particle_filter import DEFAULT_KERNEL, PFConfig
from tmaplan.evaluation.campaigns import run_one
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.experiments import CampaignSpec, resolve_policies
from tmaplan.scenario import load_problem

#: Runs 0 and 1 of the demo's stored campaigns (``tmaplan compare default --policies … --seed
#: 38``, 3000 particles, commits d491df9 / 7ddc64e) as stored before the compiled kernels
#: became the default: (time to accuracy [s] or None, final range error [m]) per policy.
NUMPY_KERNEL_RUNS = {
    "straight": ((None, 3860.760884400752), (2700.0, 1554.747445997089)),
    "single-turn": ((990.0, 295.36089032709424), (810.0, 800.2408154622972)),
    "planned": ((495.0, 1072.779144596585), (855.0, 821.6713365994183)),
}


def test_the_compiled_kernels_are_the_default():
    assert DEFAULT_KERNEL == "numba"
    assert PFConfig(dt=15.0, q=1e-4).kernel == "numba"
    assert FilterOptions().kernel == "numba"
    for opts, kernel in ((FilterOptions(), "numba"), (FilterOptions(kernel="numpy"), "numpy"),
                         (FilterOptions.plain(), "numba"),
                         (dataclasses.replace(FilterOptions.plain(), kernel="numpy"), "numpy")):
        f = opts.build(PFConfig(dt=15.0, q=1e-4, kernel="numba"))
        pf = getattr(f, "inner", f)
        assert pf.config.kernel == kernel


@pytest.mark.parametrize("kernel", ["numbа", "", None, "NUMPY"])
def test_a_bad_kernel_is_refused_naming_the_field(kernel):
    with pytest.raises(ArgumentError, match=r"filter_options\.kernel"):
        FilterOptions(kernel=kernel)


def test_each_kernel_has_its_own_campaign_key():
    sc = load_problem("default")
    spec = CampaignSpec(scenario=sc, policies=("straight",), runs=2)
    numba = dataclasses.replace(spec, filter_options=FilterOptions())
    numpy = dataclasses.replace(spec, filter_options=FilterOptions(kernel="numpy"))
    assert spec._meta()["pf_kernel"] == numba._meta()["pf_kernel"] == "numba"
    assert numpy._meta()["pf_kernel"] == "numpy"
    # the options' repr (in the key of campaigns stored with options) is what it was before
    # the field existed: the kernel enters the key once, as pf_kernel
    assert repr(FilterOptions(kernel="numpy")) == repr(FilterOptions())
    assert "kernel" not in repr(FilterOptions())
    a, b = numba._meta(), numpy._meta()
    assert {k for k in a if a[k] != b[k]} == {"pf_kernel"}
    assert len({spec.key(), numba.key(), numpy.key()}) == 3


def test_labels_name_a_kernel_that_is_not_the_default():
    assert FilterOptions().label() == "monitored"
    assert FilterOptions(kernel="numpy").label() == "monitored,kernel=numpy"
    assert dataclasses.replace(FilterOptions.robust(), kernel="numpy").label() == (
        "robust,kernel=numpy")
    odd = FilterOptions(bearing_clutter=0.01, kernel="numpy").label()
    assert odd.startswith("clutter=0.01,") and odd.endswith(",kernel=numpy")


def test_the_numpy_kernel_flies_the_campaigns_stored_before_the_switch():
    """The path before the switch stays callable: ``FilterOptions(kernel="numpy")`` gives the
    stored runs' values (tolerances of ``tests/test_headline_stored.py``: one time step, 1 % or
    1 m, for another machine's rounding); the compiled kernels give other values (other random
    numbers: the same results in distribution, ``tests/estimators/test_pf_numba.py``)."""
    sc = load_problem("default")
    names = tuple(NUMPY_KERNEL_RUNS)
    policies = resolve_policies(sc, names)
    live = {}
    for kernel in ("numpy", "numba"):
        spec = CampaignSpec(scenario=sc, policies=names, runs=2, seed=38, n_particles=3000,
                            filter_options=FilterOptions(kernel=kernel))
        live[kernel] = [run_one(spec, policies, i) for i in range(2)]
    dt = sc.time.dt
    moved = 0
    for name, runs in NUMPY_KERNEL_RUNS.items():
        for i, (t, e) in enumerate(runs):
            m = live["numpy"][i].policies[name].metrics
            tl = m.time_to_accuracy if math.isfinite(m.time_to_accuracy) else None  # never
            assert (t is None and tl is None) or (
                t is not None and tl is not None and abs(tl - t) <= dt), (name, i, t, tl)
            assert abs(m.final_range_error - e) <= max(1.0, 0.01 * abs(e)), (name, i, e)
            other = live["numba"][i].policies[name].metrics
            moved += abs(other.final_range_error - e) > max(1.0, 0.01 * abs(e))
    assert moved >= 4  # the default kernel is not the numpy one under another name
