"""The seed rig's machine for the seed's data sets (Voronin's thesis, chapter 3).

The seed author's identified simulation model (``models/params.m`` of
github.com/xvoron/thesis) and the rig's supply as its recordings show it: what
:func:`pdmkit.ensembles.simulate_seed_ensemble` records with ``rig="seed"``.
"""

from __future__ import annotations

import numpy as np

from pdmkit.ensembles._pneumatic_faults import _P_AMBIENT

__all__ = [
    "SEED_RIG_LARGE_DAMPING_SCALE",
    "SEED_RIG_PARAMS",
    "SEED_SUPPLY_CODE_DRIFT",
    "SEED_SUPPLY_CODE_SPREAD",
    "seed_rig_machine",
]

#: Code-to-code spread (relative standard deviation of the gauge pressure) of the
#: regulated supply: the rig's reservoir reading's 10 s mean differs between fault
#: codes far more than between the repeats of one code (the author's
#: ``sb/sensor_pressure/PressureAllFeatures.mat``): its 4160 nominal-supply
#: recordings spread by 0.021 bar (1-99 %: 5.93-6.03 bar), a code's 20 repeats by
#: 0.0022 bar, and the faults themselves spread the twin's by 0.0037 bar; the rest,
#: sqrt(0.021^2 - 0.0037^2) = 0.0207 bar at 6 bar, is 0.34 %. The reading drifts
#: over the recording sessions (5.988 -> 6.014 -> 5.998 bar over the table's first
#: 120 recordings; correlation of recordings 20, 100, 200 and 500 apart: 0.62, 0.44,
#: 0.22, 0.12), and the seed recorded the codes of one fault place together, so the
#: wander is 30 % independent per code and 70 % a drift along the codes in the
#: design's order (label by label), correlated 0.9 from one code to the next
#: (``SEED_SUPPLY_CODE_DRIFT``). (Before, every code of a supply set point got the
#: same pressure: the twin's pressure sensor told the labels apart at 61 %, the
#: rig's at 77 % with the same recipe.)
SEED_SUPPLY_CODE_SPREAD = 3.4e-3
#: (share of the code-to-code variance that drifts, correlation from code to code)
SEED_SUPPLY_CODE_DRIFT = (0.7, 0.9)

#: The seed rig's own machine, from the seed author's identified simulation model
#: (``models/params.m`` of github.com/xvoron/thesis; [e] identified, [c] constant
#: there), for the seed's data set. The twin's defaults are a generic 25 mm cylinder
#: with a 0.5 kg piston whose end dampers (50-1500 N s/m over 8 mm) let it strike the
#: stops at about 0.5 m/s; the rig's heavy lever (6.8 kg) creeps the last 10-13 mm
#: into 1.1-6.8 kN s/m dampers, as its recordings show (``data11_1_1..3.mat``: up to
#: 0.182 m in 0.7 s, then 0.182 -> 0.194 m over 3 s), and its upper proximity switch
#: sits in that creep, 1.3 mm below the stop (the switch stays off in 1237 of the 4840
#: recordings, ``ProximityAllFeatures.mat``).
SEED_RIG_PARAMS = {
    "mass_piston": 6.7798462575453,  # M [e]
    "bore": 0.02,  # d_A [c]
    "rod_diameter": 0.008,  # d_S [c]
    "stroke": 0.19382,  # gp: the hard stop from the bottom stop
    "v_dead_a": 0.25 * np.pi * 0.02**2 * 0.015,  # V_0A = S_A * 0.015
    "v_dead_b": 0.25 * np.pi * (0.02**2 - 0.008**2) * 0.015,  # V_0B = S_B * 0.015
    # the small dampers' coefficients identified over the fault codes
    # (b_small_bot 1082.6 at setting 7, b_small_up 6760.2 at setting 6) and their
    # reach: bot_damp_start 10.54 mm, gp - up_damp_start 12.59 mm (mean 11.5 mm); no
    # return spring (k_small_bot = k_small_up = 0 [e])
    "damper_small_min": 1082.6,
    "damper_small_max": 6760.2,
    "damper_small_travel": 0.0115,
    "damper_small_stiffness": 0.0,
    "proximity_distance": 0.19382 - 0.1925,  # gp - prox_up_band
    # valve paths: valve and throttle in series give the identified healthy
    # coefficients C_A_out 5.155e-7, C_B_out 9.1476e-7, C_A_in 6.0242e-7 and C_B_in
    # 1.7518e-7 with the throttle at its mark (1e-6 m^2; c_throttle_max 2e-6
    # [assumed]). The rig's throttles restrict both directions: they are Festo
    # GRP-160-1/8-AL (the author's doc/notes/pneustand_components.md), flow control
    # valves without the check valve of the one-way GRLA series, and the rig's own
    # recordings show it: each throttle also slows the stroke that fills its chamber
    # (throttle valve 2 lowers the down stroke's FlowContraction peak by 12.5 %,
    # throttle valve 1 the up stroke's FlowExtrusion peak by 8.7 %: medians of the
    # valve2, valve1 and healthy labels of sb/sensor_flow/FlowsFeaturesAll.mat), which
    # a throttle bypassed while its chamber fills cannot do (the twin with one-way
    # throttles: 0.0 % and 0.4 %; with these, throttle 2 still only 0.4 %, see
    # docs/seed_study.md)
    "c_throttle_max": 2e-6,
    "c_check_valve": 0.0,
    "c_a_out": 6.02e-7,
    "c_b_out": 2.26e-6,
    "c_a_in": 7.547e-7,
    "c_b_in": 1.779e-7,
    # the supply behind the pressure transmitter (params.m has none: P_s constant):
    # estimated from the rig's healthy recordings (data11_1_1..3.mat), whose reading
    # sags 0.3 bar (6.05 -> 5.73) while 36 l/min fill chamber A (FlowExtrusion) and
    # recovers within 0.1 s of the stroke's end (5.78 -> 5.97 bar): a 1e-6 m^2 feed
    # (0.3 bar at 7.2e-4 kg/s, eq. 4.13) into 0.1 l. The twin's 5e-6 m^2 into 1 l sag
    # 0.03 bar at these flows.
    "c_supply": 1.0e-6,
    "v_reservoir": 1.0e-4,
    # the static frame, estimated from the same recordings: at the stroke-end impacts
    # its accelerometer moves 0.09 (up) and 0.16 (down) times as much as the moving
    # one (100 ms standard deviations above the 0.08 g noise: 0.12 / 1.32 g and
    # 0.38 / 2.30 g), the twin's 8 kg frame about 2.1 times: 8 * 2.1 / 0.125 kg
    "frame_mass": 135.0,
}

#: Sensor-physics constants of ``SEED_RIG_PARAMS``: one number for every member.
_SEED_RIG_SCALAR = ("frame_mass",)

#: The rig's large dampers: b_large 1400 N s/m [e] of ``params.m`` against the twin's
#: nominal 400 of :data:`PNEUMATIC_FAULTS`; their healthy and worn ranges scale alike.
SEED_RIG_LARGE_DAMPING_SCALE = 1400.0 / 400.0

#: Parameters whose value per member (drawn around the twin's nominal for the
#: ``"code"`` and ``"member"`` variations) scales to the seed rig's nominal.
_SEED_RIG_SCALED = ("c_a_in", "c_a_out", "c_b_in", "c_b_out")


def seed_rig_machine(cols: dict, n: int) -> dict[str, np.ndarray]:
    """Parameter columns of ``n`` members on the seed rig's machine (``SEED_RIG_PARAMS``).

    ``cols`` holds the members' own columns (knobs, loads, ...); the machine's values
    replace or scale them (the valve coefficients drawn around the twin's nominal keep
    their spread, scaled to the rig's nominal). Missing scaled columns start from the
    twin's nominal.

    Examples
    --------
    >>> from pdmkit.ensembles._pneumatic_rig import seed_rig_machine
    >>> m = seed_rig_machine({"damper_large_damping": [400.0]}, 1)
    >>> float(m["mass_piston"][0]), float(m["damper_large_damping"][0])
    (6.7798462575453, 1400.0)
    """
    from pdmkit.models import PneumaticParams

    nominal = PneumaticParams()
    out = dict(cols)
    for key, value in SEED_RIG_PARAMS.items():
        if key in _SEED_RIG_SCALAR:
            out[key] = float(value)
        elif key in _SEED_RIG_SCALED:
            own = np.asarray(out.get(key, getattr(nominal, key)), dtype=float)
            out[key] = np.broadcast_to(own, (n,)) * (value / float(getattr(nominal, key)))
        else:
            out[key] = np.full(n, float(value))
    large = np.asarray(out.get("damper_large_damping", nominal.damper_large_damping))
    out["damper_large_damping"] = large * SEED_RIG_LARGE_DAMPING_SCALE
    return out


def _seed_rig_columns(cols, codes, seed: int, n_members: int) -> dict[str, np.ndarray]:
    """The design's parameter columns on the seed rig (:func:`seed_rig_machine`).

    ``codes``: each member's fault code number; the supply of a code wanders by
    ``SEED_SUPPLY_CODE_SPREAD`` (one draw per code number, whatever part is simulated).
    """
    out = seed_rig_machine(cols, len(codes))
    share, phi = SEED_SUPPLY_CODE_DRIFT
    noise = np.random.default_rng([seed, 2]).standard_normal((2, n_members))
    drift = np.empty(n_members)
    drift[0] = noise[1, 0]
    for i in range(1, n_members):  # AR(1) along the code numbers, unit variance
        drift[i] = phi * drift[i - 1] + np.sqrt(1.0 - phi * phi) * noise[1, i]
    wander = (np.sqrt(1.0 - share) * noise[0] + np.sqrt(share) * drift)[codes]
    gauge = (out["p_supply"] - _P_AMBIENT) * (1.0 + SEED_SUPPLY_CODE_SPREAD * wander)
    out["p_supply"] = _P_AMBIENT + gauge
    return out
