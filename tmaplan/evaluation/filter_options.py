"""The closed loop's filter options: robust measurement models, the monitor, the alarm response.

:class:`FilterOptions` bundles the robust measurement models of the particle filter
(:class:`tmaplan.estimators.particle_filter.PFConfig` ``bearing_clutter`` and ``ping_gate``),
the consistency monitor (:class:`tmaplan.estimators.consistency.MonitorConfig`) and the closed
loop's answer to its alarms (:class:`tmaplan.policies.AlarmResponse`): the filter's parts are
the estimators', the answer to an alarm is the closed loop's (a policy wrapped by the response,
:func:`tmaplan.evaluation.closed_loop.run_closed_loop`), so the options live here, above both.
:meth:`FilterOptions.plain`, :meth:`FilterOptions.monitored`, :meth:`FilterOptions.robust`,
:meth:`FilterOptions.responsive` and :meth:`FilterOptions.glr` are presets the fault matrix
compares (``benchmarks/faults.py``). A campaign's key holds ``repr(filter_options)``
(:class:`tmaplan.experiments.CampaignSpec`): the class name and its fields keep the stored
campaigns' keys valid (the particle filter's kernel, :attr:`FilterOptions.kernel`, is left out
of the repr and enters the key on its own, as ``pf_kernel``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

from tmaplan.errors import ArgumentError
from tmaplan.estimators.consistency import MonitorConfig, MonitoredFilter
from tmaplan.estimators.particle_filter import DEFAULT_KERNEL, ParticleFilter, PFConfig
from tmaplan.policies.alarms import AlarmResponse

__all__ = ["FilterOptions"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilterOptions:
    """Closed-loop filter options: robust measurement models, the monitor and the answer to its
    alarms.

    Attributes
    ----------
    bearing_clutter : float
        :attr:`tmaplan.estimators.particle_filter.PFConfig.bearing_clutter` (0: Gaussian
        bearings).
    ping_gate : float, optional
        :attr:`tmaplan.estimators.particle_filter.PFConfig.ping_gate` [σ].
    monitor : MonitorConfig, optional
        None: no monitoring.
    alarm_response : AlarmResponse, optional
        The closed loop's answer to the monitor's alarms
        (:class:`tmaplan.policies.AlarmResponse`; None: none, or no monitor).
    kernel : {"numba", "numpy"}
        :attr:`tmaplan.estimators.particle_filter.PFConfig.kernel` (default
        :data:`tmaplan.estimators.particle_filter.DEFAULT_KERNEL`, the compiled kernels;
        "numpy" gives the runs flown before they became the default again — runs stored
        without filter options are recomputed, not reused, their key being another — and is
        the closed loop's path before issue 42 in ``benchmarks/closed_loop.py``).
    """

    bearing_clutter: float = 0.0
    ping_gate: float | None = None
    monitor: MonitorConfig | None = dataclasses.field(default_factory=MonitorConfig)
    alarm_response: AlarmResponse | None = None
    kernel: Literal["numba", "numpy"] = dataclasses.field(default=DEFAULT_KERNEL, repr=False)

    def __post_init__(self) -> None:
        if self.kernel not in ("numba", "numpy"):
            raise ArgumentError("filter_options.kernel", "'numba' or 'numpy'", self.kernel)

    @classmethod
    def plain(cls) -> FilterOptions:
        """Gaussian bearings, every ping, no monitor (the filter of earlier releases)."""
        return cls(monitor=None)

    @classmethod
    def monitored(cls) -> FilterOptions:
        """Gaussian bearings with the monitor and its recovery (the closed-loop default); no
        alarm pings, so a run never uses more pings than the scenario's budget."""
        return cls()

    @classmethod
    def robust(cls) -> FilterOptions:
        """5 % clutter bearings, pings gated at 10 σ, the monitor; no alarm pings."""
        return cls(bearing_clutter=0.05, ping_gate=10.0)

    @classmethod
    def responsive(cls) -> FilterOptions:
        """:meth:`monitored` plus alarm pings: each alarm is answered with pings from the
        allowance :attr:`tmaplan.policies.AlarmResponse.extra_pings` *on top of* the
        scenario's ping budget. Opt-in, because those pings reveal the own ship beyond the
        budget the user set."""
        return cls(alarm_response=AlarmResponse())

    @classmethod
    def glr(cls) -> FilterOptions:
        """:meth:`monitored` plus the velocity-jump GLR test over 40 steps."""
        return cls(monitor=MonitorConfig(glr_window=40))

    def label(self) -> str:
        """Short name: "plain", "monitored", "robust", "responsive", "glr" or the field
        values; followed by ``,kernel=numpy`` for the kernel that is not the default."""
        kernel = f",kernel={self.kernel}" if self.kernel != DEFAULT_KERNEL else ""
        fields = dataclasses.replace(self, kernel=DEFAULT_KERNEL)
        for name in ("plain", "monitored", "robust", "responsive", "glr"):
            if fields == getattr(FilterOptions, name)():
                return name + kernel
        return (f"clutter={self.bearing_clutter},gate={self.ping_gate},"
                f"monitor={self.monitor is not None},"
                f"alarm_pings={self.alarm_response is not None}{kernel}")

    def build(self, config: PFConfig) -> Any:
        """The filter: a :class:`ParticleFilter` with these likelihood options and
        :attr:`kernel` (they replace ``config``'s), monitored if asked."""
        pf = ParticleFilter(dataclasses.replace(config, bearing_clutter=self.bearing_clutter,
                                                ping_gate=self.ping_gate, kernel=self.kernel))
        return pf if self.monitor is None else MonitoredFilter(pf, self.monitor)
