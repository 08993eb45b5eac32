"""Scenes a user can write, run and look at.

* :mod:`~.schema` — TOML scene files (``docs/scenes.md``) read with :mod:`tomllib`
  and validated into a :class:`SceneSpec`; defects raise :class:`SceneFileError`
  naming the file, the key path and the reason.
* :mod:`~.generators` — ``[[generate]]`` setups (random packing, hopper, stack,
  wall, Kapla tower).
* :mod:`~.builder` — the spec as :class:`socp_cd.dynamics.Scene` / ``Simulation``.
* :mod:`~.simulate` — ``socp-cd simulate``: run with a progress bar and write the
  HDF5 trajectory, a ParaView time series, FCLib step problems and PNG frames.

Typical use::

    from socp_cd.scenes import load_scene_file, build_scene, simulate
    spec = load_scene_file("examples/sphere_pile.toml")
    scene = build_scene(spec)                       # a socp_cd.dynamics.Scene
    summary = simulate("examples/sphere_pile.toml", steps=50, vtk="out/vtk")
"""
from .builder import build_scene, has_boxes, load_simulation
from .schema import SceneFileError, SceneSpec, load_scene_file, validate_scene
# the function, bound after its submodule of the same name is loaded: a lazy wrapper here was
# replaced by the submodule whenever ``socp_cd.scenes.simulate`` was imported first.  The
# attribute is the function, so reach the module by ``from socp_cd.scenes.simulate import ...``
# or ``importlib.import_module`` (``import socp_cd.scenes.simulate as m`` binds the function)
from .simulate import simulate  # noqa: E402,I001


__all__ = ["SceneFileError", "SceneSpec", "load_scene_file", "validate_scene", "build_scene",
           "load_simulation", "has_boxes", "simulate"]
