"""``workspace:`` section of scenario files (``mechkin workspace SCENARIO.yaml``).

Registered with :func:`mechkin.config.scenario.register_task_section` on import. Two kinds:

``kind: lee_spherical`` (lee §3, Figs. 2-5)
    sigma_KI maps over an alpha-beta grid at named sets of gamma, and gamma_min/gamma_max over
    the alpha-beta plane. ``parameters`` overrides the design (``r``, ``R``, ``center``,
    ``stroke``); values missing there come from the mechanism file (when it names the frames
    ``base_u1``, ``plate_s1``, ``center`` and the leg joint ``l1``), else from lee §3.2
    (R = 1, P = (0, 0, 1), stroke 0.5..2).

``kind: joint_sweep`` (any mechanism)
    Sweep the independent joints on a grid (``method: grid``, every joint given ``n`` points)
    or uniformly at random (``method: monte_carlo`` with ``samples`` and ``seed``) within their
    limits (or the ``range`` given per joint), and map the reachable positions of a frame.
    Closed chains are closed sample by sample from a solved neighbour (``seed_from``).

``kind: task_space`` (any mechanism)
    Sweep task-space poses of a frame through the batched inverse kinematics
    (:func:`mechkin.solvers.ik.solve_ik_batch`): a grid of positions (``positions``:
    per axis ``{range, n}`` or ``{value}``) with a fixed ``orientation`` (``method: grid``), or
    seeded random positions in the ``positions`` box (``method: monte_carlo`` with ``samples``,
    ``seed``; ``orientation: {random: true}`` draws uniform random orientations too). Maps
    reachability and dexterity (isotropy / condition number, Yoshikawa manipulability) at the
    solutions.

Design sweeps (``design: {parameter, values}``, kind lee_spherical): the maps are computed once
per value of a design parameter (``r``, ``R``, ``l_min``, ``l_max``; lengths in the file's unit)
and drawn side by side with a comparison table. Jobs (design values, task-space chunks) run on
``workers`` processes (default min(cpu count, jobs)), or on a Dask cluster with ``executor:
{kind: dask, address: "tcp://..."}`` (optional extra ``mechkin[dask]``).

Angles are in the scenario's angle unit, lengths in its length unit; :mod:`mechkin.tasks.workspace`
converts them to SI.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from mechkin.config.ik_spec import EulerSpec
from mechkin.config.scenario import register_task_section
from mechkin.config.schema import Name, NonNegNum, Num, PosNum, Spec

Pair = Annotated[list[Num], Field(min_length=2, max_length=2)]
GridN = Annotated[int, Field(strict=True, ge=2, le=100_001)]

__all__ = [
    "AxisGridSpec",
    "GammaRangeSpec",
    "JointRangeSpec",
    "DesignSpec",
    "ExecutorSpec",
    "LeeParametersSpec",
    "OrientationSpec",
    "PositionAxisSpec",
    "WorkspaceSpec",
]


def _increasing(p: list[float], what: str) -> None:
    if not p[0] < p[1]:
        raise ValueError(f"{what}: expected [lo, hi] with lo < hi, got {p}")


class AxisGridSpec(Spec):
    """A uniform grid axis: ``range`` [lo, hi] (inclusive, file angle unit) and ``n`` points."""

    range: Pair
    n: GridN

    @model_validator(mode="after")
    def _check(self) -> AxisGridSpec:
        _increasing(self.range, "range")
        return self


class GammaRangeSpec(Spec):
    """gamma_min/gamma_max over the alpha-beta plane (lee Fig. 2).

    ``range`` and ``n``: the gamma grid searched; ``mode``: ``extent`` (smallest/largest grid
    gamma in the workspace) or ``component`` (the run of workspace containing ``ref``; needs
    ``ref``); ``n_alpha``/``n_beta``: the alpha-beta grid of this map, over the section's
    alpha and beta ranges. See :mod:`mechkin.solvers.workspace.maps`.
    """

    range: Pair
    n: GridN = 361
    mode: Literal["extent", "component"] = "extent"
    ref: Num | None = None
    n_alpha: GridN = 91
    n_beta: GridN = 91

    @model_validator(mode="after")
    def _check(self) -> GammaRangeSpec:
        _increasing(self.range, "range")
        if self.mode == "component" and self.ref is None:
            raise ValueError("mode component needs ref (the gamma the run must contain)")
        return self


class LeeParametersSpec(Spec):
    """Design of lee's mechanism (lengths in the file's length unit): top-plate radius ``r``,
    base radius ``R``, centre of rotation ``center`` and leg ``stroke`` [l_min, l_max]."""

    r: PosNum | None = None
    R: PosNum | None = None
    center: Annotated[list[Num], Field(min_length=3, max_length=3)] | None = None
    stroke: Pair | None = None

    @model_validator(mode="after")
    def _check(self) -> LeeParametersSpec:
        if self.stroke is not None:
            _increasing(self.stroke, "stroke")
            if self.stroke[0] < 0:
                raise ValueError(f"stroke: expected l_min >= 0, got {self.stroke}")
        return self


class JointRangeSpec(Spec):
    """One swept joint: ``range`` [lo, hi] (default: its limits) and, for a grid, ``n``."""

    range: Pair | None = None
    n: GridN | None = None

    @model_validator(mode="after")
    def _check(self) -> JointRangeSpec:
        if self.range is not None:
            _increasing(self.range, "range")
        return self


class SlicesSpec(Spec):
    """Section planes of the point-cloud plot: ``axis`` normal (x, y or z), ``at`` the plane
    offsets (file length unit; default: the cloud's median) and ``thickness`` of each slab."""

    axis: Literal["x", "y", "z"] = "z"
    at: list[Num] | None = None
    thickness: PosNum | None = None


class DesignSpec(Spec):
    """A design sweep: the mechanism ``parameter`` and its ``values`` (file length unit).

    One set of maps per value, drawn side by side (a row per value) with a comparison table.
    """

    parameter: Literal["r", "R", "l_min", "l_max"]
    values: Annotated[list[PosNum], Field(min_length=1, max_length=64)]

    @model_validator(mode="after")
    def _check(self) -> DesignSpec:
        if len(set(self.values)) != len(self.values):
            raise ValueError(f"values: expected distinct values, got {self.values}")
        return self


class ExecutorSpec(Spec):
    """Where the jobs of a sweep run: ``kind: process`` (local processes, ``workers`` of the
    section) or ``kind: dask`` with the scheduler ``address`` (needs ``mechkin[dask]``)."""

    kind: Literal["process", "dask"] = "process"
    address: Annotated[str, Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _check(self) -> ExecutorSpec:
        if self.kind == "dask" and self.address is None:
            raise ValueError("kind dask needs address (e.g. tcp://127.0.0.1:8786)")
        if self.kind == "process" and self.address is not None:
            raise ValueError("address: only for kind dask")
        return self


class PositionAxisSpec(Spec):
    """One position axis of a task-space sweep: ``value`` (fixed), or ``range`` [lo, hi] with
    ``n`` grid points (``method: grid``; n = 1 takes the midpoint) or as the box of random
    positions (``method: monte_carlo``)."""

    value: Num | None = None
    range: Pair | None = None
    n: Annotated[int, Field(strict=True, ge=1, le=100_001)] | None = None

    @model_validator(mode="after")
    def _check(self) -> PositionAxisSpec:
        if (self.value is None) == (self.range is None):
            raise ValueError("give either value or range")
        if self.range is not None:
            _increasing(self.range, "range")
        if self.value is not None and self.n is not None:
            raise ValueError("n: only with range")
        return self


class OrientationSpec(Spec):
    """Orientation of the task-space poses: intrinsic ``euler`` (``convention``, ``angles``),
    a ``quaternion`` (w, x, y, z), or ``random: true`` (uniform, seeded; monte_carlo only).
    Default: the identity."""

    euler: EulerSpec | None = None
    quaternion: Annotated[list[Num], Field(min_length=4, max_length=4)] | None = None
    random: bool = False

    @model_validator(mode="after")
    def _check(self) -> OrientationSpec:
        given = sum([self.euler is not None, self.quaternion is not None, self.random])
        if given > 1:
            raise ValueError("give one of euler, quaternion or random: true")
        if self.quaternion is not None and sum(v * v for v in self.quaternion) < 1e-18:
            raise ValueError("quaternion: expected a non-zero (w, x, y, z)")
        return self


class WorkspaceSpec(Spec):
    """``workspace:`` section, see the module docstring.

    lee_spherical keys: ``parameters``, ``threshold``, ``alpha``, ``beta``, ``isotropy_maps``
    (name -> list of gammas, e.g. ``text: [20, 30, 40]``, ``captions: [20, 40, 60]``),
    ``gamma_range``, ``method`` (``closed_form`` or ``svd`` singular values).
    joint_sweep keys: ``method`` (``grid`` or ``monte_carlo``), ``joints``, ``samples``,
    ``seed``, ``frame`` (default: the end effector), ``voxel`` (edge of the cubes counted for
    the volume), ``slices``, ``manipulability``, ``chunk``, ``seed_from`` (``neighbour``: each
    sample's loop closure starts from a solved neighbour, keeping one assembly mode; ``home``:
    from the home configuration) and ``mode_jump`` (threshold of the mode-change report,
    dependent-joint jump / independent-joint step).
    task_space keys: ``method``, ``positions`` (x, y, z), ``orientation``, ``samples``,
    ``seed``, ``frame``, ``weights`` (6, diagonal of W), ``restarts``, ``max_iter``, ``chunk``
    (poses per job).
    lee_spherical and task_space: ``poses`` (an explicit list instead of or besides the grids:
    lee ``[alpha, beta, gamma]`` in the angle unit; task_space ``[x, y, z]`` in the length unit
    with the section's ``orientation``, or ``[x, y, z, qw, qx, qy, qz]``) or ``poses_csv`` (a
    CSV file relative to the scenario with columns ``alpha, beta, gamma`` resp. ``x, y, z`` and
    optionally ``qw, qx, qy, qz``, same units).
    joint_sweep and task_space: ``characteristic_length`` (file length unit) dividing the
    translational rows of the Jacobian for ``isotropy_normalized`` (default: the length that
    best conditions the sampled workspace, reported in summary.json).
    Every kind: ``workers``, ``executor``; lee_spherical also ``design``.
    """

    kind: Literal["lee_spherical", "joint_sweep", "task_space"]
    # lee_spherical
    parameters: LeeParametersSpec | None = None
    threshold: NonNegNum = 0.01
    alpha: AxisGridSpec | None = None
    beta: AxisGridSpec | None = None
    isotropy_maps: dict[Name, Annotated[list[Num], Field(min_length=1, max_length=12)]] | None = (
        None
    )
    gamma_range: GammaRangeSpec | None = None
    # joint_sweep (and "closed_form"/"svd" for lee)
    method: Literal["closed_form", "svd", "grid", "monte_carlo"] | None = None
    joints: dict[Name, JointRangeSpec] | None = None
    samples: Annotated[int, Field(strict=True, ge=1, le=10_000_000)] | None = None
    seed: Annotated[int, Field(strict=True, ge=0)] = 0
    frame: Name | None = None
    voxel: PosNum | None = None
    slices: SlicesSpec | None = None
    manipulability: bool = True
    characteristic_length: PosNum | None = None
    seed_from: Literal["neighbour", "home"] = "neighbour"
    mode_jump: PosNum = 2.0
    chunk: Annotated[int, Field(strict=True, ge=1, le=1_000_000)] = 2000
    # task_space
    positions: dict[Literal["x", "y", "z"], PositionAxisSpec] | None = None
    orientation: OrientationSpec | None = None
    weights: Annotated[list[NonNegNum], Field(min_length=6, max_length=6)] | None = None
    restarts: Annotated[int, Field(strict=True, ge=0, le=1000)] = 8
    max_iter: Annotated[int, Field(strict=True, ge=1, le=100_000)] | None = None
    # explicit pose lists (lee_spherical and task_space)
    poses: Annotated[list[Annotated[list[Num], Field(min_length=3, max_length=7)]],
                     Field(min_length=1, max_length=1_000_000)] | None = None
    poses_csv: Annotated[str, Field(min_length=1)] | None = None
    # design sweeps and execution
    design: DesignSpec | None = None
    workers: Annotated[int, Field(strict=True, ge=1, le=1024)] | None = None
    executor: ExecutorSpec | None = None

    @model_validator(mode="after")
    def _check(self) -> WorkspaceSpec:
        lee_keys = ("parameters", "alpha", "beta", "isotropy_maps", "gamma_range", "design")
        if self.kind == "lee_spherical" and "characteristic_length" in self.model_fields_set:
            raise ValueError("characteristic_length: not used by kind lee_spherical (sigma_KI "
                             "of Euler-angle rates needs no length scale)")
        sweep_keys = ("joints", "samples", "frame", "voxel", "slices", "seed_from", "mode_jump")
        task_keys = ("positions", "orientation", "weights", "restarts", "max_iter")
        given = self.model_fields_set
        if self.poses is not None and self.poses_csv is not None:
            raise ValueError("give poses or poses_csv, not both")
        listed = self.poses is not None or self.poses_csv is not None
        if listed and self.kind == "joint_sweep":
            raise ValueError("poses, poses_csv: only for kinds lee_spherical and task_space")
        if self.poses is not None:
            widths = {len(p) for p in self.poses}
            allowed = {3} if self.kind == "lee_spherical" else {3, 7}
            if len(widths) != 1 or not widths <= allowed:
                what = ("[alpha, beta, gamma]" if self.kind == "lee_spherical" else
                        "[x, y, z] or [x, y, z, qw, qx, qy, qz]")
                raise ValueError(f"poses: expected every pose as {what}, got lengths "
                                 f"{sorted(widths)}")
            if widths == {7} and any(sum(v * v for v in p[3:]) < 1e-18 for p in self.poses):
                raise ValueError("poses: expected non-zero quaternions (qw, qx, qy, qz)")
        if self.kind == "task_space" and listed:
            wrong = [k for k in (*lee_keys, "joints", "voxel", "slices", "manipulability",
                                 "seed_from", "mode_jump", "positions", "samples") if k in given]
            if wrong:
                raise ValueError(f"{', '.join(wrong)}: not used by kind task_space with poses")
            if self.method is not None:
                raise ValueError("method: not used with poses (the list is the sweep)")
            if self.orientation is not None and self.orientation.random:
                raise ValueError("orientation.random: only for method monte_carlo")
            return self
        if self.kind == "task_space":
            wrong = [k for k in (*lee_keys, "joints", "voxel", "slices", "manipulability",
                                 "seed_from", "mode_jump") if k in given]
            if wrong:
                raise ValueError(f"{', '.join(wrong)}: not used by kind task_space")
            if self.method not in ("grid", "monte_carlo"):
                raise ValueError("method: expected grid or monte_carlo for kind task_space")
            if not self.positions or set(self.positions) != {"x", "y", "z"}:
                raise ValueError("positions: expected x, y and z (each {value} or {range, n})")
            if self.method == "grid":
                if self.samples is not None:
                    raise ValueError("samples: only for method monte_carlo")
                if self.orientation is not None and self.orientation.random:
                    raise ValueError("orientation.random: only for method monte_carlo")
                no_n = [k for k, a in self.positions.items() if a.range is not None and a.n is None]
                if no_n:
                    raise ValueError(f"positions: method grid needs n for {', '.join(no_n)}")
            else:
                if self.samples is None:
                    raise ValueError("method monte_carlo needs samples")
                with_n = [k for k, a in self.positions.items() if a.n is not None]
                if with_n:
                    raise ValueError(f"positions: n is for method grid ({', '.join(with_n)})")
            return self
        wrong_task = [k for k in task_keys if k in given]
        if wrong_task:
            raise ValueError(f"{', '.join(wrong_task)}: only for kind task_space")
        if self.kind == "lee_spherical":
            wrong = [k for k in sweep_keys if k in given]
            if wrong:
                raise ValueError(f"{', '.join(wrong)}: not used by kind lee_spherical")
            if self.method not in (None, "closed_form", "svd"):
                raise ValueError(f"method: expected closed_form or svd for kind lee_spherical, "
                                 f"got {self.method}")
            if not self.isotropy_maps and self.gamma_range is None and not listed:
                raise ValueError("kind lee_spherical needs isotropy_maps, gamma_range and/or "
                                 "poses (or poses_csv)")
            if listed and self.design is not None:
                raise ValueError("poses: not used by design sweeps")
        else:
            wrong = [k for k in lee_keys if k in given]
            if wrong:
                raise ValueError(f"{', '.join(wrong)}: not used by kind joint_sweep")
            if self.method not in ("grid", "monte_carlo"):
                raise ValueError("method: expected grid or monte_carlo for kind joint_sweep")
            if self.method == "monte_carlo" and self.samples is None:
                raise ValueError("method monte_carlo needs samples")
            if self.method == "grid" and self.samples is not None:
                raise ValueError("samples: only for method monte_carlo")
        return self


register_task_section("workspace", WorkspaceSpec)
