"""The gait report as text for the terminal."""

from __future__ import annotations

from quadpipe.analysis.report import HILDEBRAND_ORDER, AnimalGait, ControllerEffort, GaitReport


def format_report(report: GaitReport) -> str:
    """The report as text for the terminal: per animal, the gait, stride and a table of the feet."""
    if not report.animals:
        return "no animals in the clip"
    return "\n\n".join(_format_animal(animal) for animal in report.animals)


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
