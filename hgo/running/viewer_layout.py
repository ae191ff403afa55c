"""How a run looks in the Rerun viewer: the colours of its signals, the default blueprint
(one view per plant state with its estimates, beside one view of their errors) and the
name the viewer lists the recording by (a sweep's job: its overrides).

Colours: a plant's states are drawn light grey and wide, each observer's estimates and
errors in that observer's own colour, so x and x^ differ in every view.
"""

from __future__ import annotations

import dataclasses

from omegaconf import DictConfig

from hgo.engine.system import System
from hgo.outputs.recording import Series, time_series_views

STATE_COLOR = (190, 190, 190)  # the plant's states: light grey, wide (a dark viewer)
STATE_WIDTH = 3.0
#: one colour per observer (Okabe & Ito: distinguishable with colour-vision deficiencies)
OBSERVER_COLORS = ((230, 159, 0), (86, 180, 233), (0, 158, 115), (213, 94, 0),
                   (204, 121, 167), (0, 114, 178), (240, 228, 66))


def styled(system: System, series: list[Series]) -> list[Series]:
    """``series`` with the plant's states and each observer's estimate and error in their
    colours (other series keep the palette by column)."""
    colour = {o.name: OBSERVER_COLORS[k % len(OBSERVER_COLORS)]
              for k, o in enumerate(system.observers)}
    out = []
    for s in series:
        parts = s.entity.strip("/").split("/")
        if parts[:2] == ["plant", "x"]:
            s = dataclasses.replace(s, color=STATE_COLOR, width=STATE_WIDTH)
        elif (parts[0] == "observer" and parts[-1] == "xhat" or parts[0] == "error") \
                and len(parts) >= 2 and parts[1] in colour:
            s = dataclasses.replace(s, color=colour[parts[1]])
        out.append(s)
    return out


def _only(names: list[str], keep: str):
    """A view override showing only the column ``keep`` of an entity."""
    import rerun as rr

    return rr.SeriesLines.from_fields(visible_series=[n == keep for n in names])


def state_groups(system: System, series: list[Series]) -> list[tuple[str, dict[str, str]]]:
    """Per plant state two views, as (title, entity -> the one column shown): the state
    with every observer's estimate of it, then their errors."""
    entities = {s.entity: s.names for s in series}
    groups = []
    for state in system.plant.state_names:
        shown = {"/plant/x": state}
        shown.update({e: f"{state}_hat" for e, names in entities.items()
                      if e.endswith("/xhat") and f"{state}_hat" in names})
        errors = {e: f"e_{state}" for e, names in entities.items()
                  if e.startswith("/error/") and f"e_{state}" in names}
        groups += [(f"{state} and its estimates", shown), (f"estimation error of {state}",
                                                           errors)]
    return groups


def blueprint(system: System, series: list[Series]):
    """The views of :func:`state_groups` in two columns (a state beside its errors), then
    the observers' gains and internal signals, and the measurement."""
    import rerun.blueprint as rrb

    entities = {s.entity: s.names for s in series}
    views = [rrb.TimeSeriesView(name=title, origin="/", contents=[f"+ {e}" for e in chosen],
                                overrides={e: _only(entities[e], col)
                                           for e, col in chosen.items()})
             for title, chosen in state_groups(system, series)]
    gains = [e for e in entities if e.startswith("/observer/") and not e.endswith("/xhat")]
    rest = {"observer gains and internal signals": gains or ["/observer/**"],
            "measurement": ["/measurement/**"] + (["/input/u"] if "/input/u" in entities
                                                  else [])}
    views += time_series_views(rest, entities=list(entities))
    return rrb.Blueprint(rrb.Grid(*views, grid_columns=2), auto_views=False)


def short_key(key: str) -> str:
    """``observer.standard.eps`` -> ``standard.eps``; two parts or fewer unchanged."""
    parts = key.lstrip("+~").split(".")
    return ".".join(parts[-2:])


def recording_name(cfg: DictConfig, run_dir_name: str) -> str:
    """The overrides of the run's command line but the preset (``standard.eps=0.01
    noise.std=0.001``), or the run directory's name when there are none."""
    from hgo.core.validate import task_overrides

    shown = [f"{short_key(k)}={v}" for k, _, v in (o.partition("=") for o in
                                                     task_overrides(cfg))
             if not k.lstrip("+~").startswith(("experiment", "hydra"))]
    return " ".join(shown) or run_dir_name
