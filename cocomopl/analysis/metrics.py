"""Figures of merit for any motion, planned or measured (OC, primitives, Kajita, MuJoCo).

Plain functions of :class:`Motion` objects; SI units.  Where a measured motion is compared
with its reference, the reference is interpolated onto the measured times (its duplicated
touchdown samples dropped first).
"""

from __future__ import annotations

import numpy as np

from cocomopl.dynamics import SIDES, sole_placements
from cocomopl.motion import Motion
from cocomopl.robot import Robot

GRAVITY = 9.81
CONTACT_FORCE = 20.0  # N: a sole carrying less is not standing on the ground (slip test)
FALL_HEIGHT_RATIO = 0.6  # pelvis below this fraction of its starting height: fallen


def _intervals(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Indices and lengths of the intervals of nonzero duration."""
    dt = np.diff(motion.t)
    k = np.flatnonzero(dt > 0)
    return k, dt[k]


def mean_torque(motion: Motion) -> float:
    """The paper's Table I measure, ``(∫ τᵀτ dt)^½ / (N t_f)``, in N m s^-½.

    ``N`` actuated joints, ``t_f`` the duration; torques hold over each interval (zero-order
    hold, the :class:`Motion` convention), so the integral is ``Σ |τ_k|² Δt_k``.  The paper
    reports 15.6 for both its OC and MP motions on HRP-2 (units as printed there).
    """
    k, dt = _intervals(motion)
    integral = float(np.sum(np.sum(motion.tau[k] ** 2, axis=1) * dt))
    return float(np.sqrt(integral) / (motion.tau.shape[1] * motion.duration))


def vertical_forces(motion: Motion) -> np.ndarray:
    """Vertical contact force (n, 2) of the (left, right) sole, N."""
    return motion.wrenches[..., 2]


def peak_force_over_weight(motion: Motion, mass: float) -> float:
    """Largest vertical force on one sole divided by the robot's weight."""
    return float(vertical_forces(motion).max() / (mass * GRAVITY))


def force_rates(motion: Motion) -> np.ndarray:
    """Rate of change (m, 2) of each sole's vertical force between consecutive samples, N/s."""
    k, dt = _intervals(motion)
    f = vertical_forces(motion)
    return (f[k + 1] - f[k]) / dt[:, None]


def max_force_rate(motion: Motion) -> float:
    """Largest |dF_z/dt| of either sole, N/s (the paper's Fig. 8 shows the forces)."""
    rates = force_rates(motion)
    return float(np.abs(rates).max()) if len(rates) else 0.0


def force_rate_rms(motion: Motion) -> float:
    """RMS of dF_z/dt over both soles, N/s: lower is smoother."""
    rates = force_rates(motion)
    return float(np.sqrt(np.mean(rates**2))) if len(rates) else 0.0


def _at(reference: Motion, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``values`` (per reference sample) linearly interpolated at ``times`` (relative to start)."""
    keep = reference.kept_samples()
    t = reference.t[keep] - reference.t[0]
    v = values[keep]
    return np.stack([np.interp(times, t, v[:, i]) for i in range(v.shape[1])], axis=1)


def zmp_rms_error(measured: Motion, reference: Motion) -> float:
    """RMS horizontal distance (m) of the measured ZMP from the reference ZMP at the same time.

    Samples where either ZMP is undefined (no foot pushing) are left out.
    """
    keep = reference.kept_samples()
    ok = np.all(np.isfinite(reference.zmp[keep, :2]), axis=1)
    t_ref = reference.t[keep][ok] - reference.t[0]
    ref = np.stack([np.interp(measured.t - measured.t[0], t_ref, reference.zmp[keep][ok, i]) for i in range(2)], axis=1)
    error = np.linalg.norm(measured.zmp[:, :2] - ref, axis=1)
    error = error[np.isfinite(error)]
    return float(np.sqrt(np.mean(error**2))) if len(error) else float("nan")


def knee_torques(robot: Robot, motion: Motion) -> dict[str, np.ndarray]:
    """Knee torque (n,) of each leg, N m (the paper's Fig. 9)."""
    return {side: motion.tau[:, roles["knee"]] for side, roles in robot.leg_roles().items()}


def tracking_error(measured: Motion, reference: Motion) -> dict[str, float]:
    """Joint-angle error of the measured motion against the reference, rad: RMS and max."""
    ref = _at(reference, reference.q[:, 7:], measured.t - measured.t[0])
    error = measured.q[:, 7:] - ref
    return {"rms": float(np.sqrt(np.mean(error**2))), "max": float(np.abs(error).max())}


def fell(motion: Motion) -> bool:
    """Did the robot fall?  The simulator's verdict if recorded, else the pelvis height."""
    if "fell" in motion.meta:
        return bool(motion.meta["fell"])
    return bool(motion.q[:, 2].min() < FALL_HEIGHT_RATIO * motion.q[0, 2])


def foot_slip(robot: Robot, motion: Motion) -> float:
    """Largest horizontal drift (m) of a sole while it carries at least ``CONTACT_FORCE``."""
    soles = sole_placements(robot, motion.q)
    loaded = vertical_forces(motion) > CONTACT_FORCE
    worst = 0.0
    for j in range(len(SIDES)):
        k = 0
        while k < motion.n:
            if not loaded[k, j]:
                k += 1
                continue
            first = k
            while k < motion.n and loaded[k, j]:
                k += 1
            drift = np.linalg.norm(soles[first:k, j, :2] - soles[first, j, :2], axis=1)
            worst = max(worst, float(drift.max()))
    return worst


def summary(robot: Robot, measured: Motion, reference: Motion) -> dict:
    """The figures ``cocomopl walk`` and ``simulate`` report, JSON-ready."""
    knees = knee_torques(robot, measured)
    tracking = tracking_error(measured, reference)
    return {
        "fell": fell(measured),
        "fall_time_s": measured.meta.get("fall_time_s"),
        "peak_force_over_weight": peak_force_over_weight(measured, robot.mass),
        "max_force_rate": max_force_rate(measured),
        "force_rate_rms": force_rate_rms(measured),
        "mean_torque": mean_torque(measured),
        "mean_torque_reference": mean_torque(reference),
        "zmp_rms_error": zmp_rms_error(measured, reference),
        "knee_torque_peak": float(max(np.abs(k).max() for k in knees.values())),
        "tracking_rms_rad": tracking["rms"],
        "tracking_max_rad": tracking["max"],
        "foot_slip_m": foot_slip(robot, measured),
        "duration_s": measured.duration,
        "distance_m": float(measured.q[-1, 0] - measured.q[0, 0]),
    }
