"""The movement-primitive model: its bound, its gradients, conditioning, synthesis and the CLI.

A deliberately small model (3 primitives, 30 grid points, 30 L-BFGS iterations) is fitted
once on the bundled dataset; the tests check properties, not accuracy.
"""

import itertools
import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.gait import M_GEN, parse_sequence_mm, sequence_specs
from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.model_file import model_arrays
from cocomopl.primitives.training import (
    load_training_steps,
    phase_templates,
    resample,
    split_phases,
    step_type,
)
from cocomopl.synthesis.step_chain import OutOfSupportWarning, generate_steps

from conftest import assert_one_line_error, run_cli

DATASET = BUNDLED_DATASET


@pytest.fixture(scope="module")
def steps():
    return load_training_steps(DATASET)


@pytest.fixture(scope="module")
def model(steps):
    return MovementPrimitives(n_primitives=3, kernel="matern52", n_grid=30, max_iterations=30).fit(steps)


@pytest.fixture(scope="module")
def model_file(model, tmp_path_factory):
    from cocomopl.primitives.model_file import save_model

    path = tmp_path_factory.mktemp("model") / "small.npz"
    save_model(path, model, {"robot": "talos", "command": "pytest"})
    return path


def test_time_normalisation_aligns_phase_boundaries(steps):
    templates = phase_templates(steps)
    for spec, pt in zip(steps.specs, steps.phase_time):
        b = templates[step_type(spec)]
        assert len(b) == round(pt[-1]) + 1
        assert b[0] == 0.0 and b[-1] == 1.0 and np.all(np.diff(b) > 0)
    # the grid values at the ends are the step's first and last samples
    X = resample(steps.subset([0]), templates, np.linspace(0, 1, 7))
    np.testing.assert_allclose(X[0, :, 0], steps.values[0][0])
    np.testing.assert_allclose(X[0, :, -1], steps.values[0][-1])


def test_cutting_stops_at_their_middle_touchdown_keeps_every_sample(steps):
    parts, types = split_phases(steps, "stop", 2)
    stops = [k for k, s in enumerate(steps.specs) if s.kind == "stop"]
    assert len(parts) == len(steps) + len(stops) and len(types) == len(parts)
    first = [k for k, t in enumerate(types) if t.endswith("_part1")]
    assert len(first) == len(stops)
    for k, j in zip(stops, first):
        assert types[j + 1] == types[j].replace("_part1", "_part2")
        # the parts meet at the touchdown sample and together are the step, phases and all
        assert parts.phase_time[j][-1] == 2 and parts.phase_time[j + 1][0] == 0
        np.testing.assert_array_equal(np.vstack([parts.values[j], parts.values[j + 1][1:]]), steps.values[k])
        np.testing.assert_array_equal(np.concatenate([parts.durations[j], parts.durations[j + 1]]), steps.durations[k])
    templates = phase_templates(parts, types)
    assert len(templates[types[first[0]]]) == 3 and len(templates[types[first[0] + 1]]) == 4
    X = resample(parts, templates, np.linspace(0, 1, 5), types=types)
    np.testing.assert_array_equal(X[first[0], :, -1], X[first[0] + 1, :, 0])
    with pytest.raises(Error, match="cannot cut it at phase 5"):
        split_phases(steps, "stop", 5)
    with pytest.raises(Error, match="3 step types given"):
        phase_templates(steps, ["cyclic_left"] * 3)


@pytest.mark.slow
def test_gradient_matches_finite_differences(steps):
    import jax
    import jax.numpy as jnp
    from jax.flatten_util import ravel_pytree

    from cocomopl.primitives.bound import free_energy
    from cocomopl.primitives.estimator import SlotLayout
    from cocomopl.primitives.optimise import initial_parameters

    few = steps.subset(range(0, len(steps), 4))
    tau = np.linspace(0, 1, 12)
    layout = SlotLayout(few, [step_type(s) for s in few.specs])
    X = resample(few, phase_templates(few), tau)
    params, data = initial_parameters(layout.to_slots(X), layout.mask, layout.d2, tau=tau, S=2,
                                      signal_weights=np.ones(X.shape[1]))
    rng = np.random.default_rng(0)
    params = {k: v + 0.05 * rng.standard_normal(np.shape(v)) for k, v in params.items()}
    flat, unravel = ravel_pytree({k: jnp.asarray(v) for k, v in params.items()})
    f = jax.jit(lambda x: free_energy(unravel(x), data, "rbf"))
    grad = np.asarray(jax.grad(lambda x: free_energy(unravel(x), data, "rbf"))(flat))
    for i in rng.choice(flat.size, 25, replace=False):
        e = np.zeros(flat.size)
        h = 1e-6 * max(1.0, abs(float(flat[i])))
        e[i] = h
        numeric = (float(f(flat + e)) - float(f(flat - e))) / (2 * h)
        assert numeric == pytest.approx(grad[i], rel=1e-4, abs=1e-4 * (1 + abs(numeric)) + 1e-6)


def test_fit_reports_bound_and_explained_variance(model, steps):
    assert np.isfinite(model.bound_)
    assert set(model.explained_variance_) == {"joints", "zmp", "pelvis"}
    assert all(0.8 < v <= 1.0 for v in model.explained_variance_.values())
    # whole steps, each stop's second part conditioned on its first, score a little lower
    assert 0.5 < model.score(steps) <= 1.0


def test_explained_variance_is_one_when_exact_zero_at_the_means_and_per_group(steps):
    from cocomopl.primitives.estimator import explained_variance, signal_groups

    names = steps.signal_names
    X = resample(steps, phase_templates(steps), np.linspace(0, 1, 20))
    means = np.broadcast_to(X.mean(axis=(0, 2), keepdims=True), X.shape)
    assert explained_variance(X, X, names) == {"joints": 1.0, "zmp": 1.0, "pelvis": 1.0}
    np.testing.assert_allclose(list(explained_variance(X, means, names).values()), 0.0, atol=1e-12)
    # half of each ZMP deviation missed leaves a quarter of its variance, and the other groups whole
    zmp = signal_groups(names)["zmp"]
    halfway = X.copy()
    halfway[:, zmp] = (X[:, zmp] + means[:, zmp]) / 2
    scores = explained_variance(X, halfway, names)
    assert scores["zmp"] == pytest.approx(0.75, abs=1e-12) and scores["joints"] == scores["pelvis"] == 1.0


def _short_cyclic(steps, low: float, high: float):
    return steps.subset(k for k, s in enumerate(steps.specs) if s.kind == "cyclic" and low <= s.start_length <= high)


def test_more_primitives_explain_more_of_every_group(steps):
    cyclic = _short_cyclic(steps, 0.0, 0.25)
    one, three = (MovementPrimitives(n_primitives=S, n_grid=15, max_iterations=5).fit(cyclic) for S in (1, 3))
    for group, value in one.explained_variance_.items():
        assert three.explained_variance_[group] > value, group


def test_a_second_fit_on_other_steps_predicts_as_a_fresh_fit(steps):
    """Whatever prediction derived from the first fit (per-type solves, the primitives'
    moments, the signal names) goes with it: the refitted model predicts exactly as a new one."""
    first, second = _short_cyclic(steps, 0.0, 0.25), _short_cyclic(steps, 0.3, 0.4)
    settings = {"n_primitives": 2, "n_grid": 15, "max_iterations": 3}
    model = MovementPrimitives(**settings).fit(first).prepare()
    spec, other = first.specs[0], second.specs[0]
    assert np.all(model.predict(spec, start=model.predict(spec).values[-1]).std >= 0)  # every cache filled
    model.fit(second)
    fresh = MovementPrimitives(**settings).fit(second)
    assert model.types == fresh.types and model.signal_names == fresh.signal_names
    for name, value in model_arrays(fresh).items():
        np.testing.assert_array_equal(model_arrays(model)[name], value, err_msg=name)
    for s in (spec, other):
        start = fresh.predict(other).values[-1]
        for refitted, new in ((model.predict(s), fresh.predict(s)), (model.predict(s, start), fresh.predict(s, start))):
            np.testing.assert_array_equal(refitted.values, new.values)
            np.testing.assert_array_equal(refitted.std, new.std)
            np.testing.assert_array_equal(refitted.durations, new.durations)
            assert (refitted.distance, refitted.in_support) == (new.distance, new.in_support)


@pytest.mark.slow
def test_without_jax_the_model_predicts_and_fit_names_the_extra_to_install():
    """The base install has no JAX: loading and predicting need none, fitting says in one
    line which extra to install, as the command line does."""
    script = """
import sys
sys.modules["jax"] = None  # as on the base install: importing jax fails
from cocomopl import BUNDLED_DATASET, BUNDLED_MODEL, Error, MovementPrimitives, StepSpec, load_training_steps
from cocomopl.primitives.model_file import load_model
load_model(BUNDLED_MODEL).predict(StepSpec("cyclic", 0.3, 0.3, "left")).values
try:
    MovementPrimitives().fit(load_training_steps(BUNDLED_DATASET))
except Error as exc:
    print(exc)
"""
    result = subprocess.run([sys.executable, "-c", script], check=False, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout == ("MovementPrimitives.fit needs the [train] extra: pip install 'cocomopl[train]' "
                             "(or pip install -e '.[train]')\n")


def test_prediction_at_training_step_has_training_duration(model, steps):
    k = [s.name for s in steps.specs].index("cyclic_250_L")
    step = model.predict(steps.specs[k])
    np.testing.assert_allclose(step.durations, steps.durations[k], rtol=0.02)
    assert step.in_support and step.distance == 0.0
    assert step.values.shape == (30, 36) and np.all(step.std >= 0)


def test_a_stop_is_predicted_in_its_two_learned_parts_and_joined_at_its_middle_touchdown(model, steps):
    assert {"stop_left_part1", "stop_left_part2"} <= set(model.types) and "stop_left" not in model.types
    k = [s.name for s in steps.specs].index("stop_250_L")
    step = model.predict(steps.specs[k])
    assert len(step.durations) == 5 and len(step.boundaries) == 6
    np.testing.assert_allclose(step.durations, steps.durations[k], rtol=0.05)
    # the touchdown's normalised time appears twice, pre- and post-impact, at the phase boundary
    cut = np.flatnonzero(np.diff(step.tau) == 0)
    assert len(cut) == 1 and step.tau[cut[0]] == step.boundaries[2]
    assert step.values.shape == (60, 36) and step.std.shape == (60, 36)
    # the second part is conditioned on the first's end, as steps are on their predecessor's
    joints = slice(0, 30)
    assert np.abs(step.values[cut[0] + 1, joints] - step.values[cut[0], joints]).max() < 1e-5
    # sampled in real time, the touchdown repeats its time with each part's own end values
    from cocomopl.synthesis.world import sample_step

    t, values, _ = sample_step(step, 0.025)
    touchdown = np.flatnonzero(np.diff(t) == 0)
    assert t[touchdown[0]] == pytest.approx(step.phase_edges[2])
    np.testing.assert_allclose(values[touchdown[0]], step.values[cut[0]], atol=1e-12)
    np.testing.assert_allclose(values[touchdown[0] + 1], step.values[cut[0] + 1], atol=1e-12)


def test_predicting_steps_together_equals_predicting_each_and_a_repeated_step_once(model):
    """A walk's steps are predicted together per type (``predict_many``), a repeated step once."""
    specs = sequence_specs(list(M_GEN)) + sequence_specs([0.25] * 6)
    together = model.predict_many(specs)
    for spec, step in zip(specs, together):
        alone = model.predict(spec)
        np.testing.assert_allclose(step.values, alone.values, rtol=0, atol=1e-12)
        np.testing.assert_allclose(step.std, alone.std, rtol=0, atol=1e-12)
        np.testing.assert_allclose(step.durations, alone.durations, rtol=0, atol=1e-12)
    repeated = [k for k, spec in enumerate(specs) if spec == specs[-2]]  # a cyclic step of the steady gait
    assert len(repeated) >= 2 and all(together[k] is together[-2] for k in repeated)


def test_mirror_types_share_their_weight_solves_and_their_weights_variance(model):
    """A type and its mirror image are trained on the same step parameters, and the weight
    kernels' hyperparameters are the model's: one eigenbasis serves both, and a left and a
    right step of the same lengths have the same weight variance (their means differ)."""
    for kind in ("cyclic", "start", "transition", "stop_left_part1"):
        left = model.type_arrays(f"{kind}_left" if "part" not in kind else kind)
        right = model.type_arrays(f"{kind}_right" if "part" not in kind else kind.replace("left", "right"))
        assert left.solves is right.solves
    spec = StepSpec("transition", 0.22, 0.31)
    mirrored = StepSpec("transition", 0.22, 0.31, "right")
    steps = model.predict_many([spec, mirrored])
    np.testing.assert_allclose(steps[0]._parts[0].weight_var, steps[1]._parts[0].weight_var, rtol=1e-12)
    assert np.abs(steps[0]._parts[0].weights - steps[1]._parts[0].weights).max() > 1e-3


def test_a_model_of_fewer_candidate_widths_picks_its_widths_among_them(steps, tmp_path):
    from cocomopl.primitives.em import weight_widths
    from cocomopl.primitives.model_file import load_model, save_model

    coarse = MovementPrimitives(n_primitives=2, kernel="rbf", n_grid=20, max_iterations=3, n_widths=3).fit(steps)
    picked = np.unique(coarse.gamma_w_)
    assert len(picked) <= 3
    np.testing.assert_allclose(picked, weight_widths(3)[np.searchsorted(weight_widths(3), picked * (1 - 1e-9))])
    save_model(tmp_path / "coarse.npz", coarse, {"robot": "talos", "command": "pytest"})
    assert load_model(tmp_path / "coarse.npz").n_widths == 3


def test_pca_weights_give_each_signal_group_the_same_total_variance(steps):
    from cocomopl.primitives.estimator import pca_signal_weights, signal_groups

    X = resample(steps, phase_templates(steps), np.linspace(0, 1, 20))
    weights = pca_signal_weights(X, steps.signal_names)
    weighted = (X * weights[None, :, None]).var(axis=(0, 2))
    totals = [weighted[idx].sum() for idx in signal_groups(steps.signal_names).values()]
    np.testing.assert_allclose(totals, 1.0, rtol=1e-9)


def test_conditioning_makes_the_sequence_continuous(model):
    specs = sequence_specs(list(M_GEN))
    chained = generate_steps(model, specs)
    free = [model.predict(s) for s in specs]
    joints = slice(0, 30)
    chained_gap = max(np.abs(a.values[-1, joints] - b.values[0, joints]).max() for a, b in itertools.pairwise(chained))
    free_gap = max(np.abs(a.values[-1, joints] - b.values[0, joints]).max() for a, b in itertools.pairwise(free))
    assert chained_gap < 1e-5
    assert free_gap > 100 * chained_gap


def test_a_conditioned_start_is_as_uncertain_as_its_observation(model):
    from cocomopl.primitives.estimator import CONDITION_RATIO

    specs = sequence_specs(list(M_GEN))
    start = model.predict(specs[0]).values[-1]
    free, chained = model.predict(specs[1]), model.predict(specs[1], start=start)
    conditioned = ~model.unconditioned_
    # observed with a variance CONDITION_RATIO x the prediction's, the start keeps exactly that
    # observation's share: the weights' and the primitives' uncertainty both collapse there
    noise_level = free.std[0] * np.sqrt(CONDITION_RATIO / (1.0 + CONDITION_RATIO))
    np.testing.assert_allclose(chained.std[0, conditioned], noise_level[conditioned], rtol=1e-3)
    innovation = np.abs(start - free.values[0]).max()
    np.testing.assert_allclose(chained.values[0, conditioned], start[conditioned], atol=2 * CONDITION_RATIO * innovation)
    np.testing.assert_array_equal(chained.std[:, ~conditioned], free.std[:, ~conditioned])  # the ZMP is not conditioned
    assert np.all(chained.std <= free.std + 1e-15)


def test_a_conditioned_step_ends_where_its_footstep_puts_it(model):
    """The start's innovation fades over the step, so errors do not pass from step to step
    along a walk: a step conditioned on a start far from its own ends as the free prediction."""
    specs = sequence_specs(list(M_GEN))
    free = model.predict(specs[1])
    start = free.values[0] + 0.05
    chained = model.predict(specs[1], start=start)
    conditioned = ~model.unconditioned_
    np.testing.assert_allclose(chained.values[0, conditioned], start[conditioned], atol=1e-6)
    np.testing.assert_allclose(chained.values[-1], free.values[-1], atol=1e-12)
    moved = np.abs(chained.values - free.values)[:, conditioned].max(axis=1)
    assert np.all(np.diff(moved) <= 1e-9)  # the correction only ever shrinks


def test_the_predicted_std_is_the_spread_of_sampled_signals(model):
    """The conditioned std is the spread left after the linear prediction from the start that
    conditioning makes (the best one, tapered to nothing by the step's end), on signals
    sampled from the unconditioned step: weights from their posterior, each primitive's
    values at the start and at t drawn jointly."""
    specs = sequence_specs(list(M_GEN))
    free = model.predict(specs[1])
    chained = model.predict(specs[1], start=model.predict(specs[0]).values[-1])
    (part,), (m, m_var) = free._parts, (model.m_, model.m_var_)
    w, var = part.weights, part.weight_var
    c0 = model.m_cov_start_
    rng = np.random.default_rng(0)
    n, t = 20000, np.array([1, 2, 5, 15, 29])
    weights = w[None] + np.sqrt(var)[None] * rng.standard_normal((n, var.shape[-1]))[:, None, :]
    z0, zt = rng.standard_normal((n, len(m))), rng.standard_normal((n, len(m), len(t)))
    at_start = m[:, 0] + np.sqrt(m_var[:, 0]) * z0  # (n, S)
    # MP_s(t) given MP_s(0): the regression on the start plus an independent rest
    slope = c0[:, t] / m_var[:, :1]
    rest = np.sqrt(np.maximum(m_var[:, t] - slope * c0[:, t], 0.0))
    at_t = m[:, t] + slope * (at_start - m[:, 0])[:, :, None] + rest * zt  # (n, S, len(t))
    x0 = np.einsum("nis,ns->ni", weights, at_start)
    xt = np.einsum("nis,nsk->nki", weights, at_t)
    np.testing.assert_allclose(xt.std(axis=0), free.std[t], rtol=0.05)
    x0c, xtc = x0 - x0.mean(axis=0), xt - xt.mean(axis=0)
    beta = (xtc * x0c[:, None]).mean(axis=0) / (x0c**2).mean(axis=0)
    taper = 0.5 * (1.0 + np.cos(np.pi * model.tau_[t]))[:, None]
    left = (xtc - taper * beta * x0c[:, None]).std(axis=0)
    conditioned = ~model.unconditioned_
    np.testing.assert_allclose(left[:, conditioned], chained.std[t][:, conditioned], rtol=0.05)


def test_sequence_specs_alternate_feet_and_choose_kinds():
    specs = sequence_specs(list(M_GEN))
    assert [s.kind for s in specs] == ["start", "cyclic"] + ["transition"] * 6 + ["stop"]
    assert [s.swing_side for s in specs[:3]] == ["left", "right", "left"]
    assert (specs[3].start_length, specs[3].end_length) == (0.25, 0.35)
    assert (specs[-1].start_length, specs[-1].end_length) == (0.15, 0.0)


@pytest.mark.parametrize("text, words", [("150", ["at least two"]), ("150,-5", ["'-5'", "positive"]),
                                         ("150,nan", ["'nan'"]), ("150,abc", ["'abc'", "not a number"]), ("", ["no step"])])
def test_bad_sequences_are_refused(text, words):
    with pytest.raises(Error) as err:
        parse_sequence_mm(text)
    for w in words:
        assert w in str(err.value)


def test_out_of_support_warns_and_strict_refuses(model):
    far = sequence_specs([0.25, 0.6, 0.6])
    with pytest.warns(OutOfSupportWarning, match="mm from the nearest training step"):
        generate_steps(model, far)
    with pytest.raises(Error, match="--strict"):
        generate_steps(model, far, strict=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        generate_steps(model, sequence_specs([0.25, 0.25, 0.3, 0.3]))  # inside the support: silent


def test_unknown_step_type_is_an_error(steps):
    cyclic = [k for k, s in enumerate(steps.specs) if s.kind == "cyclic"]
    only_cyclic = MovementPrimitives(n_primitives=2, n_grid=15, max_iterations=5).fit(steps.subset(cyclic))
    with pytest.raises(Error, match="no start steps"):
        only_cyclic.predict(StepSpec("start", 0.0, 0.25, "left"))


def test_parameters_round_trip_and_a_typo_is_refused():
    model = MovementPrimitives(n_primitives=7, kernel="matern32", n_grid=50, max_iterations=20, n_widths=9, verbose=True)
    assert model.get_params() == {"n_primitives": 7, "kernel": "matern32", "n_grid": 50, "max_iterations": 20,
                                  "n_widths": 9, "verbose": True}
    assert MovementPrimitives(**model.get_params()).get_params() == model.get_params()
    assert model.set_params(n_primitives=9, kernel="rbf") is model
    assert (model.n_primitives, model.kernel) == (9, "rbf")
    with pytest.raises(Error, match="no parameter 'kernal'"):
        model.set_params(n_primitives=3, kernal="rbf")
    assert model.n_primitives == 9  # a refused call sets nothing


def test_repr_shows_the_parameters_that_differ_from_the_defaults(model):
    assert repr(MovementPrimitives()) == "MovementPrimitives()"
    custom = MovementPrimitives(n_primitives=15, kernel="matern52")
    assert repr(custom) == "MovementPrimitives(n_primitives=15, kernel='matern52')"
    assert eval(repr(custom), {"MovementPrimitives": MovementPrimitives}).get_params() == custom.get_params()
    # a fitted model shows its parameters only, not its arrays
    assert repr(model) == "MovementPrimitives(n_primitives=3, kernel='matern52', n_grid=30, max_iterations=30)"


def test_verbose_shows_the_fit_progress_and_quiet_prints_nothing(steps, capfd):
    cyclic = steps.subset(k for k, s in enumerate(steps.specs) if s.kind == "cyclic" and s.start_length <= 0.25)
    quiet = MovementPrimitives(n_primitives=2, n_grid=15, max_iterations=3).fit(cyclic)
    assert capfd.readouterr() == ("", "")
    shown = MovementPrimitives(n_primitives=2, n_grid=15, max_iterations=3, verbose=True).fit(cyclic)
    out, err = capfd.readouterr()
    assert out == "" and f"{shown.n_iter_}/3" in err and f"bound={shown.bound_:.8g}" in err
    for name, value in model_arrays(quiet).items():  # showing progress leaves the fit as it is
        np.testing.assert_array_equal(model_arrays(shown)[name], value, err_msg=name)


@pytest.mark.slow
def test_placed_walk_is_a_consistent_motion(robot):
    from cocomopl.analysis.feasibility import check_motion
    from cocomopl.data import BUNDLED_MODEL
    from cocomopl.dynamics import sole_placements
    from cocomopl.primitives.model_file import load_model
    from cocomopl.synthesis.world import place_steps

    # the bundled model: the tiny test model's steps do not all fit the legs' reach
    model = load_model(BUNDLED_MODEL)
    steps = generate_steps(model, sequence_specs([0.25, 0.25, 0.25]))
    motion = place_steps(robot, steps, dt=0.025)
    assert motion.q.shape[1] == robot.model.nq and motion.tau.shape[1] == len(robot.joint_names)
    # 2 junctions, and the stop's two touchdowns (its step, then the other foot closing up)
    assert np.all(np.diff(motion.t) >= 0) and len(motion.impacts) == 4
    report = check_motion(robot, motion, 0.7)
    assert report["inverse_dynamics_residual"] < 1e-6  # torques and wrenches realise the kinematics
    # the dynamics filter: the full-model ZMP stays in the support polygon, friction suffices
    assert report["zmp_margin"] > 0 and report["friction_ratio"] < 1
    soles = sole_placements(robot, motion.q)
    for kind, first, last in motion.phases:  # the stance sole hangs still in single support
        if kind == "ss":
            j = int(np.flatnonzero(motion.contact[first + 1])[0])
            assert np.abs(soles[first : last + 1, j] - soles[first, j]).max() < 1e-6
    # every phase lasts as predicted: a sample at a phase's edge (0.4 s lands at 0.39999...) belongs to
    # the phase it opens, so refinement poses the dataset's OCP (16 knots of double support, not 17)
    placed = [motion.t[last] - motion.t[first] for _, first, last in motion.phases]
    np.testing.assert_allclose(placed, np.concatenate([s.durations for s in steps]), atol=1e-9)
    # at rest the pelvis hangs evenly on both soles, planned together three 250 mm steps ahead
    assert soles[-1, :, 0].mean() == pytest.approx(0.75, abs=1e-6)


@pytest.mark.slow
def test_generate_cli_json_and_motion_file(model_file, tmp_path):
    from cocomopl.motion_file import read_motion

    out = tmp_path / "walk.h5"
    result = run_cli("generate", "--model", str(model_file), "--lengths-mm", "150,250,250,250", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert [s["step"] for s in payload["steps"]] == ["start_150_L", "transition_150_250_R", "cyclic_250_L", "stop_250_R"]
    assert isinstance(payload["generation_s"], float) and payload["generation_s"] > 0
    motion = read_motion(out)
    assert [s.name for s in motion.steps] == [s["step"] for s in payload["steps"]]


@pytest.mark.slow
def test_generate_cli_strict_and_bad_input(model_file, tmp_path):
    out = tmp_path / "walk.h5"
    strict = run_cli("generate", "--model", str(model_file), "--lengths-mm", "250,600,600", "--out", str(out), "--strict")
    assert_one_line_error(strict, "refused (--strict)")
    for text, word in (("150", "at least two"), ("150,-1", "positive"), ("x,150", "not a number"), ("150,250", "must repeat")):
        assert_one_line_error(run_cli("generate", "--model", str(model_file), "--lengths-mm", text, "--out", str(out)), word)
    assert not out.exists()
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    unwritable = run_cli("generate", "--model", str(model_file), "--out", str(blocker / "walk.h5"))
    assert_one_line_error(unwritable, "cannot create")


@pytest.mark.slow
def test_model_info_cli(model_file, tmp_path):
    result = run_cli("model", "info", str(model_file), "--json")
    info = json.loads(result.stdout)
    assert info["n_primitives"] == 3 and info["kernel"] == "matern52"
    assert set(info["explained_variance"]) == {"joints", "zmp", "pelvis"} and np.isfinite(info["bound"])
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a model")
    assert_one_line_error(run_cli("model", "info", str(bad)), str(bad))


@pytest.mark.slow
def test_train_cli_bad_options(tmp_path):
    assert run_cli("train", "--primitives", "0", "--out", str(tmp_path / "m.npz")).returncode == 2
    assert run_cli("train", "--kernels", "cubic", "--out", str(tmp_path / "m.npz")).returncode == 2
    assert_one_line_error(run_cli("train", "--widths", "0", "--out", str(tmp_path / "m.npz")), "--widths")
    too_many = run_cli("train", "--primitives", "200", "--kernels", "rbf", "--out", str(tmp_path / "m.npz"))
    assert_one_line_error(too_many, "200 primitives cannot exceed")
    assert_one_line_error(run_cli("train", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "m.npz")), "not found")
    (tmp_path / "a-file").write_text("")
    assert_one_line_error(run_cli("train", "--out", str(tmp_path / "a-file" / "m.npz")), "cannot create")
    (tmp_path / "a-file").unlink()
    assert list(tmp_path.iterdir()) == []
