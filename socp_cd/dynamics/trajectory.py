"""Recorded trajectories: frames in memory, HDF5 on disk.

HDF5 layout (``h5py``)::

    /            attrs: dim, ndof, h, theta, solver, formulation, n_bodies, gravity (d,),
                 mu_default, restitution_default, format="socp_cd-trajectory-1"
    /geometry    is_poly, radius, mass, poly_vertices, poly_nv, poly_of_body,
                 halfspace_point, halfspace_normal, fixed_round_center, fixed_round_radius,
                 fixed_poly_vertices, fixed_poly_nv, and in 3D hull_vertices, hull_nv,
                 hull_of_body (body-frame polyhedra of the hull bodies)
    /frames      t (F,), pos (F,n,d), angle (F,n), vel (F,n,ndof), orientation (F,n,4) (3D only),
                 contact_offsets (F+1,), and per contact (concatenated over frames):
                 pairs, obstacle, point, normal, gap, r, force, key
    /stats       one entry per step: t, n_detected, n_active, iterations, error,
                 converged, status, time_detection, time_assembly, time_solve
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from ..errors import ProblemFormatError
from .frames import ContactFrame, Frame, StepStats

_FORMAT = "socp_cd-trajectory-1"
_CFIELDS = ("pairs", "obstacle", "point", "normal", "gap", "r", "force", "key")


@dataclass
class Trajectory:
    """Frames of a run plus the per-step solver statistics.

    Attributes
    ----------
    frames : list of Frame
    stats : list of StepStats
    meta : dict
        ``dim, ndof, h, theta, solver, formulation, n_bodies, gravity, mu_default,
        restitution_default``.
    geometry : dict
        Arrays describing bodies and obstacles (for rendering and analysis).
    """

    frames: list = field(default_factory=list)
    stats: list = field(default_factory=list)
    meta: dict = field(default_factory=dict)
    geometry: dict = field(default_factory=dict)

    @classmethod
    def start(cls, sim) -> "Trajectory":
        """A trajectory holding ``sim``'s current frame and its description."""
        s = sim.sys
        geom = {
            "is_poly": s.is_poly, "radius": s.radius, "mass": s.mass,
            "poly_vertices": s.poly_local, "poly_nv": s.poly_nv, "poly_of_body": s.poly_of_body,
            "halfspace_point": s.halfspaces[0], "halfspace_normal": s.halfspaces[1],
            "fixed_round_center": s.fixed_round[0], "fixed_round_radius": s.fixed_round[1],
            "fixed_poly_vertices": s.fixed_poly[0], "fixed_poly_nv": s.fixed_poly[1],
        }
        if s.dim == 3:
            geom.update({"hull_vertices": s.hulls.V, "hull_nv": s.hulls.NV, "hull_of_body": s.hull_of_body})
        meta = {"dim": s.dim, "ndof": s.ndof, "h": sim.h, "theta": sim.theta, "solver": sim.solver,
                "formulation": sim.formulation or "auto", "n_bodies": s.n_bodies,
                "gravity": np.asarray(s.gravity, dtype=np.float64), "mu_default": s.mu_default,
                "restitution_default": s.e_default}
        return cls(frames=[sim.frame()], meta=meta, geometry={k: np.asarray(v) for k, v in geom.items()})

    def append(self, frame: Frame) -> None:
        self.frames.append(frame)

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def t(self) -> np.ndarray:
        """Frame times, (F,)."""
        return np.array([f.t for f in self.frames])

    @property
    def pos(self) -> np.ndarray:
        """Positions, (F, n, d)."""
        return np.stack([f.pos for f in self.frames])

    @property
    def angle(self) -> np.ndarray:
        return np.stack([f.angle for f in self.frames])

    @property
    def orientation(self):
        """Unit quaternions ``(w, x, y, z)``, (F, n, 4), or None in 2D."""
        if not self.frames or self.frames[0].orientation is None:
            return None
        return np.stack([f.orientation for f in self.frames])

    @property
    def vel(self) -> np.ndarray:
        """Velocities, (F, n, ndof)."""
        return np.stack([f.vel for f in self.frames])

    def stats_table(self) -> dict:
        """Per-step statistics as a dict of arrays."""
        return {f.name: np.array([getattr(s, f.name) for s in self.stats]) for f in fields(StepStats)}

    # ------------------------------------------------------------------ I/O
    def save(self, path) -> Path:
        """Write the trajectory to HDF5 (see the module docstring for the layout)."""
        import h5py

        path = Path(path)
        d = self.meta["dim"]
        with h5py.File(path, "w") as f:
            f.attrs["format"] = _FORMAT
            for k, v in self.meta.items():
                f.attrs[k] = v
            g = f.create_group("geometry")
            for k, v in self.geometry.items():
                g.create_dataset(k, data=np.asarray(v))
            fr = f.create_group("frames")
            fr["t"] = self.t
            fr["pos"] = self.pos
            fr["angle"] = self.angle
            fr["vel"] = self.vel
            if self.orientation is not None:
                fr["orientation"] = self.orientation
            counts = [fm.contacts.n for fm in self.frames]
            fr["contact_offsets"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            for name in _CFIELDS:
                arrs = [np.asarray(getattr(fm.contacts, name)) for fm in self.frames]
                fr.create_dataset(name, data=np.concatenate(arrs) if arrs else np.zeros(0),
                                  compression="gzip" if sum(counts) > 10000 else None)
            st = f.create_group("stats")
            for k, v in self.stats_table().items():
                if v.dtype.kind in "UO":
                    st.create_dataset(k, data=v.astype("S"))
                else:
                    st.create_dataset(k, data=v)
        return path

    @classmethod
    def load(cls, path) -> "Trajectory":
        """Read a trajectory written by :meth:`save`.

        Raises
        ------
        ProblemFormatError
            Missing file, wrong format tag or missing datasets.
        """
        import h5py

        path = Path(path)
        if not path.exists():
            raise ProblemFormatError("path", "file does not exist", str(path))
        try:
            with h5py.File(path, "r") as f:
                if f.attrs.get("format") != _FORMAT:
                    raise ProblemFormatError("format", f"not a {_FORMAT} file", str(path))
                meta = {k: (v.item() if hasattr(v, "item") and np.ndim(v) == 0 else v)
                        for k, v in f.attrs.items() if k != "format"}
                meta = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in meta.items()}
                geom = {k: f["geometry"][k][()] for k in f["geometry"]}
                fr = f["frames"]
                t, pos, ang, vel = fr["t"][()], fr["pos"][()], fr["angle"][()], fr["vel"][()]
                quat = fr["orientation"][()] if "orientation" in fr else None
                off = fr["contact_offsets"][()]
                cdata = {k: fr[k][()] for k in _CFIELDS}
                stt = {k: f["stats"][k][()] for k in f["stats"]}
        except KeyError as exc:
            raise ProblemFormatError("frames", f"missing dataset ({exc})", str(path)) from None
        except OSError as exc:
            raise ProblemFormatError("path", f"not a readable HDF5 file ({exc})", str(path)) from None
        d = int(meta["dim"])
        frames = []
        for k in range(t.shape[0]):
            sl = slice(off[k], off[k + 1])
            c = {n: cdata[n][sl] for n in _CFIELDS}
            c["pairs"] = c["pairs"].reshape(-1, 2)
            for n in ("point", "normal", "force"):
                c[n] = c[n].reshape(-1, d)
            c["r"] = c["r"].reshape(-1, d)
            frames.append(Frame(float(t[k]), pos[k], ang[k], vel[k], ContactFrame(**c),
                                None if quat is None else quat[k]))
        stats = []
        n = len(stt.get("t", []))
        for k in range(n):
            kw = {}
            for fl in fields(StepStats):
                if fl.name not in stt:          # written before the field existed: keep its default
                    continue
                v = stt[fl.name][k]
                kw[fl.name] = v.decode() if isinstance(v, bytes) else v.item()
            stats.append(StepStats(**kw))
        return cls(frames=frames, stats=stats, meta=meta, geometry=geom)


__all__ = ["Trajectory"]
