"""Writing what ``vsegen identify`` found: the new vehicle file and the report.

The vehicle file is the base file's text with each identified value replaced in place and its
comment saying what it was identified as (value, 95 % interval, supporting logs); everything else
(settings, comments, order) stays as the user wrote it.
"""

from __future__ import annotations

from vsegen.harness.identify import Identification
from vsegen.harness.identify.estimates import Estimate
from vsegen.harness.project.vehicles import with_settings
from vsegen.model.estimators import DEFINITIONS
from vsegen.model.params import VehicleConfig, parse_vehicle
from vsegen.model.schema import rounded

VEHICLE_KEYS = ("cornering_stiffness_front", "cornering_stiffness_rear")
"""[vehicle] keys identify may replace."""


def derived_settings(config: VehicleConfig, ident: Identification) -> dict[str, dict[str, tuple]]:
    """Per estimator of ``config``: {setting: (value, comment)} for every car-specific setting whose
    quantities were all identified."""
    out: dict[str, dict[str, tuple]] = {}
    for name in config.estimators:
        for key, derived in DEFINITIONS[name].derived.items():
            estimates = [ident.estimates.get(q) for q in derived.quantities]
            if any(e is None for e in estimates):
                continue
            value = derived.value(*(e.value for e in estimates))
            value = [rounded(v) for v in value] if isinstance(value, list) else rounded(value)
            basis = "; ".join(f"{e.name} {e.value:.4g} {e.unit} (95 % {e.low:.4g}..{e.high:.4g})"
                              for e in estimates)
            out.setdefault(name, {})[key] = (value, f"identified from {basis}")
    return out


def missing_settings(config: VehicleConfig, ident: Identification) -> list[str]:
    """The car-specific settings of ``config``'s estimators that the logs could not derive."""
    derived = derived_settings(config, ident)
    return [f"[estimator.{name}] {key}" for name in config.estimators
            for key, rule in DEFINITIONS[name].derived.items()
            if key not in derived.get(name, {}) and not rule.optional]


def identified_vehicle_file(text: str, config: VehicleConfig, ident: Identification) -> str:
    """The base file ``text`` with the identified values written in. ``[estimator] derived_for``
    is set to the new [vehicle] fingerprint only when every car-specific setting was derived."""
    vehicle = {key: ident.estimates[key] for key in VEHICLE_KEYS if key in ident.estimates}
    if vehicle:
        text = with_settings(text, "vehicle", comments={k: _comment(e) for k, e in vehicle.items()},
                             **{k: rounded(e.value) for k, e in vehicle.items()})
    for name, settings in derived_settings(config, ident).items():
        text = with_settings(text, f"estimator.{name}", comments={k: c for k, (_, c) in settings.items()},
                             **{k: v for k, (v, _) in settings.items()})
    if not missing_settings(config, ident):
        fingerprint = parse_vehicle(text, config.source, config.name).vehicle_fingerprint()
        text = _set_derived_for(text, fingerprint)
    return text


def _comment(estimate: Estimate) -> str:
    return f"identified: {estimate.describe()}"


def _set_derived_for(text: str, fingerprint: str) -> str:
    comment = "[vehicle] fingerprint the car-specific settings were identified for (vsegen identify)"
    try:
        return with_settings(text, "estimator", comments={"derived_for": comment}, derived_for=fingerprint)
    except KeyError:
        lines = text.split("\n")
        at = next(i for i, line in enumerate(lines) if line.strip() == "[estimator]")
        lines.insert(at + 1, f'derived_for = "{fingerprint}"  # {comment}')
        return "\n".join(lines)


def report(ident: Identification, config: VehicleConfig, log_names: list[str], out_name: str) -> str:
    """The markdown report: every estimate with its interval, every refusal with its reason, the
    settings written and those left for review."""
    lines = [f"# vsegen identify: {config.name} -> {out_name}", "",
             f"Logs: {', '.join(log_names)}.",
             "Ground-truth columns used: " + ("yes, beta_ref/vy_ref (optical or GNSS/INS reference) "
                                             "entered the stiffness fit." if ident.uses_reference
                                             else "none (ordinary driving only)."), "",
             "| parameter | value | 95 % interval | unit | from |", "| --- | --- | --- | --- | --- |"]
    lines += [f"| {e.name} | {e.value:.4g} | {e.low:.4g} .. {e.high:.4g} | {e.unit} | {e.support} |"
              for e in ident.estimates.values()]
    if ident.refusals:
        lines += ["", "Not identified (base values kept):", ""]
        lines += [f"* {r.name}: {r.why}" for r in ident.refusals]
    written = derived_settings(config, ident)
    lines += ["", "Settings written:", ""]
    lines += [f"* [vehicle] {key}" for key in VEHICLE_KEYS if key in ident.estimates]
    lines += [f"* [estimator.{name}] {key} = {value}" for name, settings in written.items()
              for key, (value, _) in settings.items()]
    missing = missing_settings(config, ident)
    if missing:
        lines += ["", "Left for review (not derived; `derived_for` not set, so generate/run will warn):", ""]
        lines += [f"* {m}" for m in missing]
    lines += ["", "Offsets are reported, not written: remove them in the ECU's signal conditioning. "
              "tyre_friction (the axles' peak force over their static load) is written to every Kalman "
              "filter's settings; it acts where tyre_model = \"saturating\".",
              "Intervals: least squares with serially correlated residuals (effective sample count); "
              "the stiffnesses' also cover the spread between driving stretches (jackknife)."]
    return "\n".join(lines) + "\n"
