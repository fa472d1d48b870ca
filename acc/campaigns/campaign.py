"""Campaign files: grids and random samples over scenario keys, expanded to numbered runs.

A campaign is a closed TOML file (format in ``docs/campaigns.md``)::

    [campaign]
    name = "depth_sweep"
    base = "kim_chung_2001.toml"   # scenario file, relative to this file (default: defaults)
    seed = 7                        # root seed of every run's random streams
    combine = "product"             # grid: "product" of the lists, or "zip" them
    samples_per_point = 20          # runs per grid point (random draws / noise repeats)
    record_every_steps = 0          # 0: metrics only; n: keep every n-th plant step of traces
    chunk_runs = 64                 # runs simulated and written together

    [set]                           # fixed changes to the base scenario
    simulation.time_limit_s = 40.0

    [grid]                          # section.key = [values...]
    controller.kind = ["pi", "constant"]

    [random]                        # section.key = { dist = ..., ... }
    force_process.gain_multiplier = { dist = "uniform", low = 0.8, high = 1.25 }

Run numbering.  Grid point ``g`` (row-major over the ``[grid]`` keys in file order for
``"product"``, position in the lists for ``"zip"``) and sample ``s`` give run
``g * samples_per_point + s``.

Randomness.  Every run uses the root seed as ``simulation.seed``, so the simulator's
per-run stream is child ``run`` of ``SeedSequence(seed)``.  The sampled parameter values of
run ``r`` come from that child's own first child, ``SeedSequence(seed, spawn_key=(r, 0))``,
drawn key by key in file order; the two streams are independent and neither depends on
which other runs exist, how runs are chunked or where they are simulated.

Validation.  :func:`load_campaign` checks the file (unknown keys, empty lists, bad
distributions) and :meth:`Campaign.validate` builds every run's scenario once, so a sampled
value outside a model's range is reported in one line naming the key and the run before
any run is simulated.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import itertools
import json
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acc import scenarios
from acc.errors import did_you_mean, unknown_name
from acc.inputs import read_toml
from acc.limits import MAX_INTEGER, MAX_LIST_ITEMS, MAX_RUNS, abbreviate, shorten
from acc.scenarios.force import (
    DISTURBANCE_LIST,
    SECTIONS,
    Scenario,
    ScenarioError,
    coerce_key,
    field_types,
    replace_section,
    section_error,
)
from plants.disturbance import Disturbance


class CampaignError(ScenarioError):
    """A campaign that cannot be run; the message names the file, the key and the run."""


#: Scenario keys that fix the shared time grid or the seed of a campaign: not sweepable.
FIXED_KEYS = (
    "simulation.plant_step_s",
    "simulation.control_period_s",
    "simulation.time_limit_s",
    "simulation.seed",
)
#: The same for the axis and contouring labs, whose runs are simulated one by one: only the
#: seed (each run's is drawn from the root seed, :meth:`Campaign.run_seed`).
LAB_FIXED_KEYS = ("simulation.seed",)

DISTRIBUTIONS = {
    "uniform": ("low", "high"),
    "loguniform": ("low", "high"),
    "normal": ("mean", "std"),
    "choice": ("values",),
    "integers": ("low", "high"),
}
_DIST_OPTIONAL = ("size", "quantum")

#: A campaign name: a plain file name (it names the sweep's directory under a gate's --out).
_NAME_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,99}$")

_CAMPAIGN_KEYS = {
    "name": str,
    "base": str,
    "seed": int,
    "combine": str,
    "samples_per_point": int,
    "record_every_steps": int,
    "chunk_runs": int,
    "pair_over": list,
}


@dataclass(frozen=True)
class Distribution:
    """How one scenario key is drawn for every run.

    Attributes
    ----------
    kind : {"uniform", "loguniform", "normal", "choice", "integers"}
        ``uniform``/``loguniform`` on ``[low, high)``, ``normal(mean, std)``, ``choice`` of
        ``values`` (equally likely), ``integers`` in ``[low, high]`` inclusive.
    low, high, mean, std : float or None
        Parameters of the distribution, in the key's unit.
    values : tuple or None
        The candidates of ``choice`` (numbers, strings or lists).
    size : int or None
        Draw a list of this many independent values (e.g. a radial-depth profile).
    quantum : float or None
        Round each draw to a whole multiple of this, in the key's unit (e.g. the plant
        step for a dead time).
    """

    kind: str
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = None
    values: tuple[Any, ...] | None = None
    size: int | None = None
    quantum: float | None = None

    def draw(self, rng: np.random.Generator) -> Any:
        """One value (or list of ``size`` values) from ``rng``."""
        n = 1 if self.size is None else self.size
        if self.kind == "uniform":
            x = rng.uniform(self.low, self.high, n)
        elif self.kind == "loguniform":
            x = np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))
        elif self.kind == "normal":
            x = rng.normal(self.mean, self.std, n)
        elif self.kind == "integers":
            out = [int(v) for v in rng.integers(self.low, self.high, n, endpoint=True)]
            return out if self.size is not None else out[0]
        else:  # choice
            idx = rng.integers(0, len(self.values), n)
            out = [self.values[i] for i in idx]
            return out if self.size is not None else out[0]
        if self.quantum is not None:
            x = np.round(x / self.quantum) * self.quantum
        out = x.tolist()  # Python floats
        return out if self.size is not None else out[0]


@dataclass(frozen=True)
class Campaign:
    """A validated campaign file: a base scenario and how it varies over numbered runs.

    Attributes
    ----------
    name : str
    source : str
        The campaign file (for messages).
    base : Scenario, AxisScenario or ContourScenario
        The base scenario of any lab (:mod:`acc.scenarios`) with ``[set]`` applied and, in
        the force loop, ``simulation.seed`` = the root seed.
    seed : int
        Root seed.
    combine : {"product", "zip"}
    samples_per_point : int
        Runs per grid point, >= 1.
    grid : tuple of (str, tuple)
        ``(section.key, values)`` in file order.
    random : tuple of (str, Distribution)
        ``(section.key, distribution)`` in file order.
    record_every_steps : int or None
        Trace decimation in plant steps; None keeps no traces (metrics only).
    chunk_runs : int
        Runs per chunk, >= 1.
    pair_over : tuple of str
        Grid keys the runs are paired over (e.g. ``controller.kind``): runs that differ only
        in these keys share their random draws and their noise and disturbance streams
        (common random numbers), so their differences are the keys'.
    """

    name: str
    source: str
    base: Any
    seed: int
    combine: str = "product"
    samples_per_point: int = 1
    grid: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    random: tuple[tuple[str, Distribution], ...] = ()
    record_every_steps: int | None = None
    chunk_runs: int = 64
    pair_over: tuple[str, ...] = ()

    @property
    def model(self) -> str:
        """The lab of the base scenario: ``"force"``, ``"axis"`` or ``"xy_contour"``."""
        return scenarios.model_of_scenario(self.base)

    def run_seed(self, run_id: int) -> int:
        """A lab run's ``simulation.seed``: drawn from ``SeedSequence(seed, spawn_key=(k, 1))``
        with ``k`` = :meth:`noise_id` (paired runs share it, like the force loop's streams),
        so it depends on neither the chunking nor which other runs exist."""
        seq = np.random.SeedSequence(self.seed, spawn_key=(self.noise_id(run_id), 1))
        return int(seq.generate_state(1, np.uint32)[0])

    @property
    def points(self) -> int:
        """Number of grid points (1 without a grid)."""
        if not self.grid:
            return 1
        lengths = [len(v) for _, v in self.grid]
        return lengths[0] if self.combine == "zip" else math.prod(lengths)

    @property
    def runs(self) -> int:
        """Number of runs."""
        return self.points * self.samples_per_point

    @property
    def swept_keys(self) -> tuple[str, ...]:
        """Grid keys then random keys, each once, in file order."""
        keys = [k for k, _ in self.grid]
        keys += [k for k, _ in self.random if k not in keys]
        return tuple(keys)

    def _point(self, index: int) -> dict[str, Any]:
        if not self.grid:
            return {}
        if self.combine == "zip":
            return {k: v[index] for k, v in self.grid}
        out = {}
        for key, values in reversed(self.grid):
            index, j = divmod(index, len(values))
            out[key] = values[j]
        return {k: out[k] for k, _ in self.grid}

    def noise_id(self, run_id: int) -> int:
        """The key of a run's random draws and noise streams: the run number, or with
        ``pair_over`` the run's number in the grid without the paired keys (product grids:
        the other keys' indices, row-major, times the samples, plus the sample)."""
        if not self.pair_over:
            return run_id
        point, sample = divmod(run_id, self.samples_per_point)
        index, radix = 0, 1
        for key, values in reversed(self.grid):
            point, j = divmod(point, len(values))
            if key not in self.pair_over:
                index += j * radix
                radix *= len(values)
        return index * self.samples_per_point + sample

    def values(self, run_id: int) -> dict[str, Any]:
        """The swept ``{section.key: value}`` of one run (grid value, then random draws,
        keyed by :meth:`noise_id`)."""
        if not 0 <= run_id < self.runs:
            raise IndexError(f"run {run_id} is outside 0..{self.runs - 1}")
        values = self._point(run_id // self.samples_per_point)
        if self.random:
            key = self.noise_id(run_id)
            rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(key, 0)))
            for key, dist in self.random:
                values[key] = dist.draw(rng)
        return values

    def scenario(
        self, run_id: int, values: dict[str, Any] | None = None, checked: bool = False
    ) -> Scenario:
        """The validated scenario of one run.

        Parameters
        ----------
        run_id : int
        values : dict, optional
            The run's swept values if already drawn (:meth:`values`).
        checked : bool
            The run was built once already (:meth:`validate`): the cross-section checks of
            the force loop's scenario (:func:`acc.scenarios.checks.check_scenario`, about
            15 us for a part of three segments) are not repeated; the values are still
            converted and each touched section validated.

        Raises
        ------
        CampaignError
            One line naming the campaign file, the run, the key and the value.
        """
        values = self.values(run_id) if values is None else values
        try:
            if self.model != "force":
                return self.base.with_values(
                    {**values, "simulation.seed": self.run_seed(run_id)}, source=self.source)
            return apply_values(self.base, values, source=self.source, checked=checked)
        except ScenarioError as exc:
            shown = ", ".join(f"{k} = {_format(v)}" for k, v in values.items())
            if len(shown) > 160:
                shown = shown[:157] + "..."
            detail = str(exc)
            if detail.startswith(f"{self.source}: "):
                detail = detail[len(self.source) + 2 :]
            raise CampaignError(f"{self.source}: run {run_id} ({shown}): {detail}") from None

    def scenarios(self, run_ids: Iterator[int] | list[int] | range) -> list[Scenario]:
        """Scenarios of the given runs, in order."""
        return [self.scenario(int(r)) for r in run_ids]

    def validate(self, check: Callable[[Scenario], str | None] | None = None) -> None:
        """Build every run's scenario once (nothing is kept).

        Parameters
        ----------
        check : callable or None
            Called with each scenario; returns why it cannot run, or None.

        Raises
        ------
        CampaignError
            At the first run that cannot be built (or fails ``check``).
        """
        for r in range(self.runs):
            scenario = self.scenario(r)
            why = None if check is None else check(scenario)
            if why is not None:
                raise CampaignError(f"{self.source}: run {r}: {why}")

    def to_dict(self) -> dict[str, Any]:
        """Everything that fixes the campaign's numbers, resolved, JSON-friendly."""
        return {
            "name": self.name,
            "seed": self.seed,
            "combine": self.combine,
            "samples_per_point": self.samples_per_point,
            "record_every_steps": self.record_every_steps,
            "grid": [[k, list(v)] for k, v in self.grid],
            "random": [[k, _dist_dict(d)] for k, d in self.random],
            "pair_over": list(self.pair_over),
            "model": self.model,
            "base": self.base.to_dict() if hasattr(self.base, "to_dict") else self.base.data,
            "runs": self.runs,
        }

    def fingerprint(self) -> str:
        """SHA-256 of :meth:`to_dict`: a resumed sweep must be the same campaign."""
        text = json.dumps(self.to_dict(), sort_keys=True, default=str)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


def apply_values(
    base: Scenario, values: dict[str, Any], source: str | None = None, checked: bool = False
) -> Scenario:
    """``base.with_values(values)``, rebuilding only the sections the values touch.

    Same checks and messages: each value is checked and converted by the scenario module's
    own rules (:func:`acc.scenarios.force.coerce_key`), the touched sections are rebuilt with their
    validation, and the scenario's cross-section checks run again.  Tested equal to
    :meth:`Scenario.with_values`; some 50 times faster, which matters for 1e5-run campaigns.

    Parameters
    ----------
    base : Scenario
    values : dict
        ``{"section.key": value}``.
    source : str or None
        Where the values come from, for errors (default: the base scenario's source).
    checked : bool
        The same values passed the whole validation before (a sweep's worker rebuilding a
        run its parent validated): the scenario's cross-section checks are skipped.
    """
    blame = base.source if source is None else source
    by_section: dict[str, dict[str, Any]] = {}
    for dotted, value in values.items():
        section, _, key = dotted.partition(".")
        by_section.setdefault(section, {})[key] = value
    changes = {}
    for section, table in by_section.items():
        cls = SECTIONS.get(section)
        hints = field_types(cls) if cls is not None else {}
        if cls is None or not all(k in hints for k in table):
            return base.with_values(values, source=source)  # the scenario module words it
        coerced = {k: coerce_key(section, k, v, hints[k], blame) for k, v in table.items()}
        try:
            changes[section] = replace_section(getattr(base, section), coerced)
        except ValueError as exc:
            raise section_error(blame, section, cls, exc) from None
    # the base with the touched sections swapped: what dataclasses.replace builds, without
    # its generic __init__ (7 us a run)
    built = copy.copy(base)
    for section, value in changes.items():
        object.__setattr__(built, section, value)
    if checked:  # Scenario.__post_init__ is the cross-section check: not run again
        return built
    try:
        built.__post_init__()
        return built
    except ScenarioError as exc:
        if source is None:
            raise
        raise exc.blame(source, instead_of=base.source) from None


def _dist_dict(d: Distribution) -> dict[str, Any]:
    out = {k: v for k, v in dataclasses.asdict(d).items() if v is not None}
    if "values" in out:
        out["values"] = list(out["values"])
    return out


def _format(value: Any) -> str:
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_format(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.6g}"
    return repr(value) if isinstance(value, str) else str(value)


def _known_key(dotted: str, where: str, swept: bool = True, model: str = "force") -> None:
    if model != "force":
        why = scenarios.key_problem(model, dotted)
        if why is not None:
            raise CampaignError(f"{where}: {shorten(dotted, 80)}: {why}")
        if swept and dotted in LAB_FIXED_KEYS:
            raise CampaignError(
                f"{where}: {dotted}: cannot be swept (each run's seed is drawn from the root "
                "seed; set [campaign] seed)")
        return
    section, _, key = dotted.partition(".")
    if section == DISTURBANCE_LIST:  # the whole list, or disturbance.<name>.<key>
        name, _, field_name = key.partition(".")
        names = list(field_types(Disturbance))
        if key and (not field_name or field_name not in names):
            raise CampaignError(
                f"{where}: {shorten(dotted, 80)}: expected disturbance or "
                f"disturbance.<name>.<key> with a key of {', '.join(names)}"
            )
        return
    shown = shorten(dotted, 80)
    if section not in SECTIONS:
        raise CampaignError(
            f"{where}: {shown}: unknown section {abbreviate(section)}"
            f"{did_you_mean(section, SECTIONS)} (known: {', '.join(SECTIONS)})"
        )
    names = list(field_types(SECTIONS[section]))
    if key not in names:
        raise CampaignError(f"{where}: {shown}: {unknown_name('key', key, names)}")
    if swept and dotted in FIXED_KEYS:
        raise CampaignError(
            f"{where}: {dotted}: cannot be swept (every run of a campaign shares the time grid "
            "and the root seed; put it in [set] or [campaign] seed)"
        )


def _flatten(table: Any, where: str, leaf: str) -> list[tuple[str, Any]]:
    """``{section: {key: value}}`` (or quoted ``"section.key"``) to ``[(section.key, value)]``."""
    if not isinstance(table, dict):
        raise CampaignError(f"{where}: must be a table of section.key = {leaf}")
    out = []
    for section, sub in table.items():
        if "." in section:
            out.append((section, sub))
            continue
        if section == DISTURBANCE_LIST:  # the whole list, or {name: {key: value}}
            if not isinstance(sub, dict) or leaf == "distribution" and "dist" in sub:
                out.append((section, sub))
                continue
            for name, fields in sub.items():
                if not isinstance(fields, dict):
                    raise CampaignError(f"{where}: disturbance.{name}: expected "
                                        f"disturbance.<name>.<key> = {leaf}")
                out += [(f"{section}.{name}.{key}", v) for key, v in fields.items()]
            continue
        if not isinstance(sub, dict) or (leaf == "distribution" and "dist" in sub):
            raise CampaignError(
                f"{where}: {shorten(section, 80)}: expected section.key = {leaf}"
            )
        for key, value in sub.items():
            if isinstance(value, dict) and not (leaf == "distribution" and "dist" in value):
                # a per-axis table of the contouring lab: [grid.lead_lag.x] gain = [...]
                out += [(f"{section}.{key}.{k}", v) for k, v in value.items()]
                continue
            out.append((f"{section}.{key}", value))
    return out


def _distribution(spec: Any, where: str) -> Distribution:
    if not isinstance(spec, dict) or "dist" not in spec:
        raise CampaignError(f"{where}: expected {{ dist = ..., ... }}, got {abbreviate(spec)}")
    kind = spec["dist"]
    if not isinstance(kind, str) or kind not in DISTRIBUTIONS:
        raise CampaignError(
            f"{where}: unknown dist {abbreviate(kind)} (known: {', '.join(DISTRIBUTIONS)})"
        )
    needed = DISTRIBUTIONS[kind]
    allowed = {"dist", *needed, *_DIST_OPTIONAL}
    for k in spec:
        if k not in allowed:  # (TOML keys are strings)
            raise CampaignError(
                f"{where}: unknown option {abbreviate(k)} for dist {kind!r} "
                f"(allowed: {', '.join(sorted(allowed - {'dist'}))})"
            )
    for k in needed:
        if k not in spec:
            raise CampaignError(f"{where}: dist {kind!r} needs {k!r}")
    kw: dict[str, Any] = {"kind": kind}
    for k in ("low", "high", "mean", "std", "quantum"):
        if k in spec:
            v = spec[k]
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise CampaignError(f"{where}: {k} must be a finite number, got {abbreviate(v)}")
            if kind == "integers" and k in ("low", "high"):
                if not isinstance(v, int):
                    raise CampaignError(f"{where}: dist 'integers' needs whole low and high")
                if abs(v) > MAX_INTEGER:
                    raise CampaignError(
                        f"{where}: {k} = {abbreviate(v)} is outside 64-bit integers"
                    )
                kw[k] = v
            else:
                kw[k] = float(v) + 0.0  # -0.0 as 0.0: numpy refuses uniform(0.0, -0.0)
    if "size" in spec:
        size = spec["size"]
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise CampaignError(f"{where}: size must be a whole number >= 1")
        if size > MAX_LIST_ITEMS:
            raise CampaignError(
                f"{where}: size = {size} values per draw; at most {MAX_LIST_ITEMS} (limit)"
            )
        kw["size"] = size
    if kind == "choice":
        if not isinstance(spec["values"], list) or not spec["values"]:
            raise CampaignError(f"{where}: dist 'choice' needs a non-empty list of values")
        kw["values"] = tuple(spec["values"])
    if kind in ("uniform", "loguniform", "integers") and not kw["low"] <= kw["high"]:
        raise CampaignError(f"{where}: low must be <= high, got {kw['low']} > {kw['high']}")
    if kind == "uniform" and not math.isfinite(kw["high"] - kw["low"]):
        raise CampaignError(f"{where}: high - low overflows (got {kw['low']}, {kw['high']})")
    if kind == "integers" and kw["high"] - kw["low"] >= 2**63:
        raise CampaignError(
            f"{where}: the range low..high holds more than 2**63 integers (limit)"
        )
    if kind == "loguniform" and not kw["low"] > 0:
        raise CampaignError(f"{where}: dist 'loguniform' needs low > 0")
    if kind == "normal" and not kw["std"] >= 0:
        raise CampaignError(f"{where}: std must be >= 0")
    if "quantum" in kw and not kw["quantum"] > 0:
        raise CampaignError(f"{where}: quantum must be > 0")
    return Distribution(**kw)


def campaign_from_dict(data: dict[str, Any], source: str, base_dir: Path) -> Campaign:
    """Build a :class:`Campaign` from parsed TOML; see :func:`load_campaign`."""
    known_tables = ("campaign", "set", "grid", "random")
    for table in data:
        if table not in known_tables:
            raise CampaignError(
                f"{source}: [{shorten(table, 80)}]: unknown table "
                f"(known: {', '.join(known_tables)})"
            )
    head = data.get("campaign", {})
    if not isinstance(head, dict):
        raise CampaignError(f"{source}: [campaign] must be a table, got {abbreviate(head)}")
    for key, value in head.items():
        if key not in _CAMPAIGN_KEYS:
            raise CampaignError(
                f"{source}: campaign.{shorten(key, 40)}: "
                f"{unknown_name('key', key, _CAMPAIGN_KEYS)}"
            )
        tp = _CAMPAIGN_KEYS[key]
        if isinstance(value, bool) or not isinstance(value, tp):
            wanted = "a whole number" if tp is int else "a string"
            raise CampaignError(
                f"{source}: campaign.{key}: expected {wanted}, got {abbreviate(value)}"
            )
    name = head.get("name")
    if name is not None:
        if not _NAME_RE.match(name) or set(name) <= {"."}:
            raise CampaignError(
                f"{source}: campaign.name: {abbreviate(name)} is not a plain name (letters, "
                "digits and _ . + -, at most 100, not starting with '.'); it names the "
                "sweep's directory"
            )
    else:
        name = re.sub(r"[^A-Za-z0-9_.+-]", "_", Path(source).stem)[:100].lstrip(".") or "campaign"

    if "base" in head:
        base_path = Path(head["base"])
        if not base_path.is_absolute():
            base_path = base_dir / base_path
        base = scenarios.load(base_path)
    else:
        base = Scenario(source=source)
    model = scenarios.model_of_scenario(base)

    fixed = _flatten(data.get("set", {}), f"{source}: [set]", "value")
    for key, _ in fixed:
        _known_key(key, f"{source}: [set]", swept=False, model=model)
    if fixed:
        base = base.with_values(dict(fixed), source=source)
    seed = head.get("seed", base.simulation.seed)
    if not 0 <= seed <= MAX_INTEGER:
        raise CampaignError(f"{source}: campaign.seed: must be in 0..2**63-1, got {seed}")
    if seed != base.simulation.seed and model == "force":
        base = base.with_values({"simulation.seed": seed}, source=source)

    grid = []
    for key, values in _flatten(data.get("grid", {}), f"{source}: [grid]", "[values]"):
        _known_key(key, f"{source}: [grid]", model=model)
        if not isinstance(values, list):
            raise CampaignError(
                f"{source}: grid.{key}: expected a list of values, got {abbreviate(values)}"
            )
        if not values:
            raise CampaignError(f"{source}: grid.{key}: empty list (the sweep would have no runs)")
        grid.append((key, tuple(values)))
    random = []
    for key, spec in _flatten(data.get("random", {}), f"{source}: [random]", "distribution"):
        _known_key(key, f"{source}: [random]", model=model)
        random.append((key, _distribution(spec, f"{source}: random.{key}")))

    combine = head.get("combine", "product")
    if combine not in ("product", "zip"):
        raise CampaignError(f"{source}: campaign.combine: must be 'product' or 'zip'")
    if combine == "zip" and len({len(v) for _, v in grid}) > 1:
        lengths = ", ".join(f"{k}: {len(v)}" for k, v in grid)
        raise CampaignError(f"{source}: [grid]: combine = 'zip' needs equal lengths ({lengths})")
    samples = head.get("samples_per_point", 1)
    if samples < 1:
        raise CampaignError(
            f"{source}: campaign.samples_per_point: must be >= 1, got {samples} "
            "(the sweep would have no runs)"
        )
    points = 1
    if grid:
        lengths = [len(v) for _, v in grid]
        points = lengths[0] if combine == "zip" else math.prod(lengths)
    if points * samples > MAX_RUNS:
        raise CampaignError(
            f"{source}: campaign.samples_per_point: {points} grid point(s) x {samples} "
            f"samples = {points * samples:.3g} runs (limit {MAX_RUNS:.0e} runs per campaign)"
        )
    pair_over = head.get("pair_over", [])
    grid_keys = [k for k, _ in grid]
    for key in pair_over:
        if not isinstance(key, str) or key not in grid_keys:
            raise CampaignError(
                f"{source}: campaign.pair_over: {abbreviate(key)} is not a [grid] key "
                f"({', '.join(grid_keys) or 'no grid'})"
            )
    if pair_over and combine == "zip":
        raise CampaignError(
            f"{source}: campaign.pair_over: needs combine = 'product' (zipped keys vary together)"
        )
    record = head.get("record_every_steps", 0)
    if record < 0:
        raise CampaignError(f"{source}: campaign.record_every_steps: must be >= 0")
    if record and model != "force":
        raise CampaignError(
            f"{source}: campaign.record_every_steps: a sweep of {scenarios.MODELS[model]} keeps "
            "metrics only (set 0; `acc run` one run's file for its traces)")
    chunk = head.get("chunk_runs", 64)
    if not 1 <= chunk <= MAX_RUNS:
        raise CampaignError(f"{source}: campaign.chunk_runs: must be in 1..{MAX_RUNS}")
    return Campaign(
        name=name,
        source=source,
        base=base,
        seed=seed,
        combine=combine,
        samples_per_point=samples,
        grid=tuple(grid),
        random=tuple(random),
        record_every_steps=record or None,
        chunk_runs=chunk,
        pair_over=tuple(pair_over),
    )


def load_campaign(path: str | Path) -> Campaign:
    """Read and check a campaign file (not yet every run; see :meth:`Campaign.validate`).

    Raises
    ------
    CampaignError or ScenarioError
        Missing file, TOML syntax, unknown table or key, empty sweep, bad distribution, a base
        scenario or ``[set]`` value that is invalid.
    """
    p = Path(path)
    data = read_toml(p, "campaign")
    return campaign_from_dict(data, source=str(p), base_dir=p.parent)


def grid_points(campaign: Campaign) -> Iterator[dict[str, Any]]:
    """The grid points in run order (an independent enumeration, used to check numbering)."""
    if not campaign.grid:
        yield {}
        return
    keys = [k for k, _ in campaign.grid]
    lists = [v for _, v in campaign.grid]
    combos = zip(*lists, strict=True) if campaign.combine == "zip" else itertools.product(*lists)
    for combo in combos:
        yield dict(zip(keys, combo, strict=True))


__all__ = [
    "DISTRIBUTIONS",
    "FIXED_KEYS",
    "Campaign",
    "CampaignError",
    "Distribution",
    "campaign_from_dict",
    "grid_points",
    "load_campaign",
]
