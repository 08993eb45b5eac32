"""The granular experiment builders (socp_cd.granular.samples) and the validation scripts' pieces."""
from __future__ import annotations

import numpy as np
import pytest

from socp_cd.errors import InvalidProblemError
from socp_cd.granular.samples import TalusGrains, biaxial_box_scene, feed_batch, talus_bed, talus_simulation


def test_talus_grains_survive_a_rebuild():
    """Grains → Simulation → grains keeps vertices, pose, mass and inertia (what a checkpoint relies on)."""
    tal = talus_bed(slope_deg=10.0, length=10.0)
    rng = np.random.default_rng(0)
    g = feed_batch(tal, TalusGrains.empty(), 7, rng, feed_width=4.0)
    g = feed_batch(tal, g, 5, rng, feed_width=4.0)            # second batch stacks above the first
    assert g.n == 12 and np.all((g.nv >= 5) & (g.nv <= 8))
    assert g.pos[7:, 1].min() > g.pos[:7, 1].min()
    sim = talus_simulation(tal, g, 4e-3, dict(tol=1e-6))
    back = TalusGrains.from_simulation(sim)
    for name in ("pos", "angle", "mass", "inertia", "nv"):
        np.testing.assert_allclose(getattr(back, name), getattr(g, name), atol=1e-12)
    np.testing.assert_allclose(back.world(), g.world(), atol=1e-12)
    keep = back.take(np.arange(12) % 2 == 0)
    assert keep.n == 6 and np.allclose(keep.pos, g.pos[::2])


def test_biaxial_shape_is_checked():
    with pytest.raises(InvalidProblemError):
        biaxial_box_scene(n=10, shape="ellipse")
    box = biaxial_box_scene(n=10, shape="polygon")
    assert box.n_grains == 10 and len(box.scene.bodies) == 12


@pytest.mark.slow
def test_biaxial_sample_is_at_rest_and_moreau_exact(validation_script):
    """A small biaxial box through compress → quench → static step: at rest to solver tolerance."""
    gc = validation_script("granular_convergence")
    state, W, H, info = gc.make_sample(40, "disk", max_steps=600, quench=60, final_tol=1e-8,
                                       v_wall=5e-3)
    r = gc.analyse(state, W, H, info)
    assert r["final_error"] <= 1e-7
    assert r["static_residual_over_mean_force"] < 1e-4          # inertia of the static step
    assert r["moreau_asymmetry"] < 1e-5 and r["moreau_origin_change"] < 1e-12
    assert r["decomposition_residual_any_reference"] < 1e-10
    assert 0 < r["weber_moreau_rel"] < 0.5 and r["weber_reference_change_mean"] > 0
    assert np.isfinite(r["rms_normal"]) and np.isfinite(r["rms_shear"])


def test_biaxial_compression_resumes_from_its_checkpoint(tmp_path, validation_script):
    """An interrupted compression resumed from its HDF5 checkpoint ends where an uninterrupted one does."""
    gc = validation_script("granular_convergence")
    kw = dict(quench=2, final_solver="nsgs", final_iter=200, final_tol=1e-4, max_iter=30)
    whole = gc.make_sample(20, "polygon", max_steps=40, **kw)
    ck = tmp_path / "box.ckpt.h5"
    gc.make_sample(20, "polygon", max_steps=20, checkpoint=ck, checkpoint_every=10, **kw)
    assert ck.exists()
    resumed = gc.make_sample(20, "polygon", max_steps=40, checkpoint=ck, checkpoint_every=10, **kw)
    assert resumed[3]["compress_steps"] == whole[3]["compress_steps"] == 40
    assert resumed[3]["resumed_at_step"] == 20 and whole[3]["resumed_at_step"] == 0
    np.testing.assert_array_equal(resumed[0].centers, whole[0].centers)
    np.testing.assert_array_equal(resumed[0].forces, whole[0].forces)


def test_sample_spread_reports_every_seed(validation_script):
    """cuts_sample_spread --quick: one record per shape with each seed's values, mean and spread."""
    css = validation_script("cuts_sample_spread")
    recs = css.main(["--quick"])
    assert {r["shape"] for r in recs} == {"disk", "polygon"}
    for r in recs:
        assert r["seeds"] == [1, 2] and r["n_grains"] == 40
        for k in css.KEYS:
            v = np.array(r[k]["values"])
            assert v.shape == (2,) and np.all(v > 0)
            assert r[k]["mean"] == pytest.approx(v.mean()) and r[k]["std"] == pytest.approx(v.std(ddof=1))


def test_biaxial_checkpoint_of_a_jammed_box_is_not_compressed_again(tmp_path, validation_script):
    """A crash after the walls stopped: the rerun goes straight to the quench; other settings are refused."""
    gc = validation_script("granular_convergence")
    kw = dict(quench=2, final_solver="nsgs", final_iter=200, final_tol=1e-4, max_iter=30,
              v_wall=1e3, max_steps=1000)          # any wall speed counts as stopped: jams at step 300
    ck = tmp_path / "box.ckpt.h5"
    first = gc.make_sample(20, "polygon", checkpoint=ck, checkpoint_every=100, **kw)
    rerun = gc.make_sample(20, "polygon", checkpoint=ck, checkpoint_every=100, **kw)
    assert first[3]["compress_steps"] == rerun[3]["compress_steps"] == 300
    assert rerun[3]["resumed_at_step"] == 300
    np.testing.assert_array_equal(rerun[0].centers, first[0].centers)
    with pytest.raises(SystemExit, match="another run"):
        gc.make_sample(20, "polygon", checkpoint=ck, **dict(kw, seed=1))
