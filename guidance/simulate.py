"""Closed-loop simulation of the guidance law on the nonlinear point-mass model.

The report's implementation steps ("Algorithm Implementation and Evaluation"), at each
guidance interval:

1. weights α, β, μ, ζ are given (:class:`~rangefx.guidance.law.GuidanceWeights`);
2. σ1, σ2 and ``s`` from eqs 35-36, 40-41 (:class:`~rangefx.guidance.law.ObstacleField`);
3. the time-to-go from ``H(t0) = 0`` (:func:`~rangefx.guidance.law.solve_time_to_go`);
4. the gains k1..k8 and the commanded accelerations (eqs 59-69);
5. thrust ``T``, thrust angle ``θ`` and bank ``φ`` from eqs 12-19.

Between guidance updates the controls ``(T, θ, φ)`` are held (zero-order hold, as a
digital guidance computer would) and the nonlinear eqs 1-6 are integrated with
``scipy.integrate.solve_ivp`` (DOP853, tight tolerances). The run ends when the
time-to-go falls to 1.5 guidance intervals or less: the last command is held for the
remaining ``t_go`` and the flight time is the time at that point. In the last
``terminal_time`` seconds the time-to-go counts down instead of being searched.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from .checks import check_numbers
from .law import (
    BoundaryConditions,
    NoTransversalityRootWarning,
    ObstacleField,
    command_acceleration,
    solve_time_to_go,
)
from .model import (
    Controls,
    VehicleParams,
    accelerations,
    inverse_controls,
    point_mass_rhs,
    state_from_position_velocity,
    velocity_from_state,
)

__all__ = [
    "SimulationConfig",
    "SimulationResult",
    "held_sample_times",
    "integrate_held_controls",
    "record_command",
    "result_from_record",
    "simulate",
    "trajectory_metrics",
]


@dataclass(frozen=True)
class SimulationConfig:
    """Closed-loop simulation settings.

    Parameters
    ----------
    guidance_interval
        Time between guidance updates (s), > 0.
    sample_interval
        Output sampling of the trajectory (s), > 0 and <= ``guidance_interval``;
        the minimum obstacle distance is taken on these samples.
    t_go_min, t_go_max, grid
        Time-to-go search settings (:func:`~rangefx.guidance.law.solve_time_to_go`).
    terminal_time
        Once the time-to-go is at or below this (s), it is no longer searched but counted
        down (``t_go - Δt`` per update): near the end ``H`` is dominated by the
        ``-α|a|²/2 ~ t_go⁻⁴`` term, small state errors move its root by more than they
        should, and a jump of ``t_go`` there commands a spike.
    max_time
        Abort (``RuntimeError``) if the flight has not ended by then (s).
    rtol, atol
        Integrator tolerances.
    """

    guidance_interval: float = 0.1
    sample_interval: float = 0.02
    t_go_min: float = 0.05
    t_go_max: float = 120.0
    grid: int = 400
    terminal_time: float = 0.5
    max_time: float = 200.0
    rtol: float = 1e-9
    atol: float = 1e-9

    def __post_init__(self) -> None:
        names = ("guidance_interval", "sample_interval", "t_go_min", "t_go_max")
        check_numbers("simulation", self, (*names, "terminal_time", "max_time"))
        if self.sample_interval > self.guidance_interval:
            raise ValueError(
                f"sample_interval ({self.sample_interval:g} s) must not exceed "
                f"guidance_interval ({self.guidance_interval:g} s)"
            )
        if self.t_go_min >= self.t_go_max:
            raise ValueError(f"t_go_min ({self.t_go_min:g}) must be < t_go_max ({self.t_go_max:g})")


@dataclass
class SimulationResult:
    """Time histories of a closed-loop run.

    ``t``/``states`` are sampled every ``sample_interval`` (states ``[x, y, z, V, γ, χ]``);
    the guidance arrays (``t_cmd``, ``accel_cmd``, ``accel_achieved``, ``thrust``, ``theta``,
    ``phi``, ``t_go``, ``h_residual``, ``root_found``) have one entry per guidance update.
    """

    t: np.ndarray
    states: np.ndarray
    t_cmd: np.ndarray
    accel_cmd: np.ndarray
    accel_achieved: np.ndarray
    thrust: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    t_go: np.ndarray
    h_residual: np.ndarray
    root_found: np.ndarray
    obstacles: np.ndarray
    bc: BoundaryConditions
    params: VehicleParams
    extras: dict = field(default_factory=dict)

    @property
    def positions(self) -> np.ndarray:
        return self.states[:, :3]

    @property
    def flight_time(self) -> float:
        return float(self.t[-1])

    def velocities(self) -> np.ndarray:
        return np.array([velocity_from_state(s) for s in self.states])

    def closest_obstacle_distance(self) -> np.ndarray:
        """Distance from each sampled position to the nearest obstacle point (Fig 6)."""
        d = self.positions[:, None, :] - self.obstacles[None, :, :]
        return np.sqrt((d**2).sum(axis=-1)).min(axis=1)


def record_command(
    rec: dict[str, list],
    t: float,
    a_cmd: np.ndarray,
    state: np.ndarray,
    ctrl: Controls,
    params: VehicleParams,
    t_go: float,
) -> None:
    """Append one guidance update to ``rec``: its time, the commanded and achieved
    accelerations, the controls of the inverse (eqs 17-19) and the time-to-go."""
    rec["t_cmd"].append(t)
    rec["a_cmd"].append(a_cmd)
    rec["a_ach"].append(accelerations(state, ctrl, params))
    rec["T"].append(ctrl.thrust)
    rec["th"].append(ctrl.theta)
    rec["ph"].append(ctrl.phi)
    rec["tgo"].append(t_go)


def result_from_record(
    ts: list[float],
    states: list[np.ndarray],
    rec: dict[str, list],
    *,
    h_residual: np.ndarray,
    root_found: np.ndarray,
    obstacles: np.ndarray,
    bc: BoundaryConditions,
    params: VehicleParams,
    extras: dict | None = None,
) -> SimulationResult:
    """The :class:`SimulationResult` of a flown trajectory (``ts``, ``states``) and its
    guidance updates as :func:`record_command` recorded them in ``rec``; ``h_residual``
    and ``root_found`` per update are the law's own."""
    return SimulationResult(
        t=np.asarray(ts),
        states=np.asarray(states),
        t_cmd=np.asarray(rec["t_cmd"]),
        accel_cmd=np.asarray(rec["a_cmd"]),
        accel_achieved=np.asarray(rec["a_ach"]),
        thrust=np.asarray(rec["T"]),
        theta=np.asarray(rec["th"]),
        phi=np.asarray(rec["ph"]),
        t_go=np.asarray(rec["tgo"]),
        h_residual=np.asarray(h_residual),
        root_found=np.asarray(root_found, dtype=bool),
        obstacles=obstacles,
        bc=bc,
        params=params,
        extras=extras or {},
    )


def held_sample_times(t: float, dt: float, sample_interval: float) -> tuple[float, np.ndarray]:
    """End and output times of one held-command interval ``[t, t + dt]``, sampled at most
    ``sample_interval`` apart (the last sample exactly at the end despite rounding)."""
    n_s = max(1, math.ceil(dt / sample_interval - 1e-9))
    t_end = t + dt
    return t_end, np.minimum(t + dt * np.arange(1, n_s + 1) / n_s, t_end)


def simulate(
    bc: BoundaryConditions,
    obstacles: ObstacleField,
    params: VehicleParams | None = None,
    config: SimulationConfig | None = None,
) -> SimulationResult:
    """Fly the closed-loop guidance law from ``bc.r0, bc.v0`` to ``bc.rf, bc.vf``.

    Guidance updates where ``H = 0`` has no root: the first update uses the fallback of
    :func:`~rangefx.guidance.law.solve_time_to_go` (``argmin |H|``); later ones count the
    previous time-to-go down by one guidance interval (``argmin |H|`` sits where ``H``
    peaks and does not shrink as the vehicle advances, so using it at every update would
    never end the flight). The per-update warnings are collected and one
    :class:`~rangefx.guidance.law.NoTransversalityRootWarning` summarises them.

    Raises
    ------
    RuntimeError
        If the flight does not end within ``config.max_time`` or the model leaves its
        domain (zero speed).
    """
    params = params or VehicleParams()
    cfg = config or SimulationConfig()
    state = state_from_position_velocity(bc.r0, bc.v0)
    t = 0.0
    ts, states = [0.0], [state.copy()]
    rec: dict[str, list] = {
        k: [] for k in ("t_cmd", "a_cmd", "a_ach", "T", "th", "ph", "tgo", "h", "ok")
    }
    no_root = 0
    t_go_next: float | None = None  # countdown value in the terminal phase
    while True:
        r, v = state[:3], velocity_from_state(state)
        if t_go_next is None:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", NoTransversalityRootWarning)
                ttg = solve_time_to_go(
                    r, v, bc, obstacles, t_min=cfg.t_go_min, t_max=cfg.t_go_max, grid=cfg.grid
                )
            no_root += sum(issubclass(w.category, NoTransversalityRootWarning) for w in caught)
            t_go, h_res, found = ttg.t_go, ttg.h_residual, ttg.root_found
            if not found and rec["tgo"]:
                # No root: argmin |H| does not shrink with time (it sits where H peaks),
                # so the closed loop would never end; count the last time-to-go down.
                t_go = max(rec["tgo"][-1] - cfg.guidance_interval, cfg.guidance_interval)
        else:
            # Terminal phase: H = 0 is dominated by the -α|a|²/2 ~ 1/t_go⁴ term and its
            # root moves by more than the state error explains, so t_go just counts down.
            t_go, h_res, found = t_go_next, math.nan, True
        a_cmd = command_acceleration(r, v, t_go, bc, obstacles)
        ctrl = inverse_controls(v, a_cmd, params)
        record_command(rec, t, a_cmd, state, ctrl, params, t_go)
        rec["h"].append(h_res)
        rec["ok"].append(found)
        # End within 1.5 intervals: a sliver of t_go left for one more update would
        # command the k ~ 1/t_go² gains at a tiny t_go (a thrust spike).
        last = t_go <= 1.5 * cfg.guidance_interval
        dt = t_go if last else cfg.guidance_interval
        if t_go_next is not None or t_go <= cfg.terminal_time:
            t_go_next = t_go - dt
        t_end, t_eval = held_sample_times(t, dt, cfg.sample_interval)
        sol = integrate_held_controls(state, ctrl, params, t, t_end, t_eval, cfg)
        ts.extend(sol.t.tolist())
        states.extend(sol.y.T)
        state = sol.y[:, -1].copy()
        t = float(sol.t[-1])
        if last:
            break
        if t > cfg.max_time:
            raise RuntimeError(f"flight did not end within max_time = {cfg.max_time:g} s")
    if no_root:
        warnings.warn(
            f"H(t_go) = 0 (eq 55) had no root at {no_root} of {len(rec['tgo'])} guidance "
            "updates; the time-to-go was counted down there (argmin |H| at the first update)",
            NoTransversalityRootWarning,
            stacklevel=2,
        )
    return result_from_record(ts, states, rec, h_residual=rec["h"], root_found=rec["ok"],
                              obstacles=obstacles.points, bc=bc, params=params)  # fmt: skip


def integrate_held_controls(
    state: np.ndarray,
    ctrl: Controls,
    params: VehicleParams,
    t0: float,
    t1: float,
    t_eval: np.ndarray,
    cfg: SimulationConfig,
):
    """Integrate eqs 1-6 from ``t0`` to ``t1`` with the controls held (zero-order hold).

    Returns the ``solve_ivp`` solution sampled at ``t_eval``.

    Raises
    ------
    RuntimeError
        At zero airspeed or when the integrator fails.
    """

    def rhs(_t, y):
        if y[3] <= 0:
            raise RuntimeError("airspeed reached zero: the point-mass model (eqs 2-3) is singular")
        return point_mass_rhs(y, ctrl, params)

    sol = solve_ivp(
        rhs, (t0, t1), state, method="DOP853", t_eval=t_eval, rtol=cfg.rtol, atol=cfg.atol
    )
    if not sol.success:
        raise RuntimeError(f"integration failed at t = {t0:g} s: {sol.message}")
    return sol


def trajectory_metrics(res: SimulationResult) -> dict[str, float | int]:
    """Key figures of a run (the report quotes the first five).

    ``flight_time_s``, ``min_obstacle_distance`` (ft), ``max_load_factor`` (``T/W``),
    ``max_abs_theta_deg``, ``max_abs_phi_deg``, plus ``initial_t_go_s`` (the first
    solution of eq 55), ``max_airspeed_ft_s``, ``final_position_error_ft``,
    ``final_velocity_error_ft_s``, ``guidance_updates``, ``no_root_updates``,
    ``n_obstacles``.
    """
    v_end = velocity_from_state(res.states[-1])
    return {
        "flight_time_s": res.flight_time,
        "min_obstacle_distance": float(res.closest_obstacle_distance().min()),
        "max_load_factor": float(res.thrust.max() / res.params.weight_lbf),
        "max_abs_theta_deg": float(np.degrees(np.abs(res.theta).max())),
        "max_abs_phi_deg": float(np.degrees(np.abs(res.phi).max())),
        "initial_t_go_s": float(res.t_go[0]),
        "max_airspeed_ft_s": float(res.states[:, 3].max()),
        "final_position_error_ft": float(np.linalg.norm(res.positions[-1] - res.bc.rf)),
        "final_velocity_error_ft_s": float(np.linalg.norm(v_end - res.bc.vf)),
        "guidance_updates": len(res.t_go),
        "no_root_updates": int((~res.root_found).sum()),
        "n_obstacles": len(res.obstacles),
    }
