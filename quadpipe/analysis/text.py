"""The gait report as text for the terminal."""

from __future__ import annotations

from quadpipe.analysis.direction import format_direction
from quadpipe.analysis.posture import AnimalPosture, LegPosture
from quadpipe.analysis.report import HILDEBRAND_ORDER, AnimalGait, ControllerEffort, GaitReport


def format_report(report: GaitReport) -> str:
    """The report as text for the terminal: per animal, the gait, stride and a table of the feet,
    then its posture when measured."""
    if not report.animals:
        return "no animals in the clip"
    postures = {p.name: p for p in report.posture.animals} if report.posture is not None else {}
    sections = []
    for animal in report.animals:
        posture = postures.get(animal.name)
        sections.append(_format_animal(animal) + ("" if posture is None else "\n" + format_posture(posture)))
    sections += [format_direction(direction) for direction in report.directions]
    return "\n\n".join(sections)


def figure(value: float | None, digits: int = 2) -> str:
    """A number with `digits` decimals, or `-` for None (not measured)."""
    return "-" if value is None else f"{value:.{digits}f}"


def _format_animal(a: AnimalGait) -> str:
    lines = [f"{a.name} ({a.species}, HP {a.pelvis_height:.2f} m): {a.gait.label} - {a.gait.reason}"]
    if a.stride_period_s is not None:
        lines.append(
            f"  {a.stride_count} strides: period {a.stride_period_s:.2f} s ({a.stride_frequency_hz:.2f} Hz), "
            f"length {a.stride_length_m:.2f} m = {a.stride_length_hp:.2f} HP, speed {a.speed_m_s:.2f} m/s, "
            f"Froude {a.froude:.3f}"
        )
        if a.alexander_ratio is not None:
            lines.append(
                f"  Alexander: 2.3 Fr^0.3 = {a.alexander_stride_hp:.2f} HP predicted, ratio {a.alexander_ratio:.2f}"
            )
    lines.append("  foot  duty  phase  spread  stance(s)  slip(mm)  slip(HP)")
    for leg in HILDEBRAND_ORDER:
        g = a.legs[leg]
        slip_mm = None if g.mean_slip_m is None else 1000 * g.mean_slip_m
        slip_hp = None if g.mean_slip_m is None else g.mean_slip_m / a.pelvis_height
        lines.append(
            f"  {leg.upper():4}  {figure(g.duty_factor):>4}  {figure(g.phase):>5}  {figure(g.phase_spread):>6}  "
            f"{figure(g.mean_stance_s):>9}  {figure(slip_mm, 1):>8}  {figure(slip_hp, 3):>8}"
        )
    lines.append("  controller forces: " + _format_effort(a.effort))
    lines.extend(f"  note: {note}" for note in a.notes)
    return "\n".join(lines)


def _format_effort(effort: ControllerEffort | None) -> str:
    if effort is None:
        return "not recorded"
    parts = []
    if effort.mean_net_force_bw is not None:
        parts.append(f"mean net force {effort.mean_net_force_bw:.3f} body weights")
    if effort.work_j is not None:
        parts.append(f"work {effort.work_j:.1f} J ({figure(effort.work_j_per_kg_m, 3)} J/kg/m)")
    return ", ".join(parts)


def format_posture(p: AnimalPosture) -> str:
    """An animal's posture as text: trunk, head and tail, then per foot its joints' flexion and its slip."""
    t, h = p.trunk, p.head_tail
    settled = p.first_frame / p.fps
    tail = "-" if h.tail_ground_fraction is None else f"{100 * h.tail_ground_fraction:.0f} %"
    lines = [
        f"  Posture (vs the standing pose; frames {p.first_frame}-{p.first_frame + p.frames - 1},"
        f" from {settled:.2f} s; {p.strides} strides):",
        f"    trunk: pelvis {t.pelvis_height_ratio:.2f} of standing height (min {t.pelvis_height_ratio_min:.2f}),"
        f" withers {t.withers_height_ratio:.2f}; roll {t.roll_amplitude_deg:.1f} deg amplitude"
        f" (mean {t.roll_mean_deg:+.1f}), yaw {t.yaw_amplitude_deg:.1f} deg amplitude",
        f"    head: height {h.head_dz_hp:+.3f} HP (max {h.head_dz_max_abs_hp:.3f}), pitch {h.head_pitch_deg:+.1f} deg,"
        f" neck {h.neck_angle_deg:+.1f} deg",
        f"    tail: on the ground {tail} of frames, base {h.tail_elevation_deg:+.1f} deg"
        f" (standing {h.tail_elevation_rest_deg:+.1f}), root to tip {h.tail_chord_deg:+.1f} deg",
        "    foot  stance flexion max/mean/min (deg; + closes)                  slip  drag  sink dyn/rest  clear (%HP)",
    ]
    lines.extend(_format_leg(p.legs[leg]) for leg in HILDEBRAND_ORDER)
    lines.extend(f"  note: {note}" for note in p.notes)
    return "\n".join(lines)


def _format_leg(leg: LegPosture) -> str:
    joints = "  ".join(
        f"{name} {figure(j.stance_max_deg, 0)}/{figure(j.stance_mean_deg, 0)}/{figure(j.stance_min_deg, 0)}"
        for name, j in leg.joints.items()
    )
    return (
        f"    {leg.leg.upper():4}  {joints:<60}  {_percent(leg.slip_max_hp):>4}  {_percent(leg.toe_drag_max_hp):>4}"
        f"  {_percent(leg.penetration_dynamic_hp)}/{_percent(leg.penetration_rest_hp)}  {_percent(leg.swing_clearance_hp)}"
    )


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f}"
