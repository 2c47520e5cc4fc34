"""research/diag_sidehead.py (run by hand, research/teacher_multimodal.md): the side-reading head is exactly
mirror-equivariant, reads the side it is given, and its closed-loop learner acts as the whole-episode forward."""

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.scenario import load_scenario

torch = pytest.importorskip("torch")


@pytest.fixture
def ds(repo_script):
    return repo_script("research/diag_sidehead.py")


def test_side_head_is_mirror_equivariant_and_reads_the_given_side(ds):
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies.heads import categorical_classes

    lay = tse.parallel_env(scenario=load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0)), n_robots=2).layout  # research: the sign-flip layout
    m = ds.SideHeadGRU(lay.size, lay.mirror_signs(), categorical_classes(), hidden=8, width=8, seed=1)
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (6, 3, lay.size)).astype(np.float32)
    p = rng.uniform(-1, 1, (6, 3, 2)).astype(np.float32)
    side = rng.integers(-1, 2, (6, 3))
    with torch.no_grad():
        for s in (None, side):
            o, z, _ = m.forward_aux(x, p, side=s)
            om, zm, _ = m.forward_aux(lay.mirror(x).astype(np.float32), mirror_action(p),
                                      side=None if s is None else -s)
            np.testing.assert_allclose(om.numpy(), o.numpy()[..., m.perm.numpy()], atol=1e-6)
            np.testing.assert_allclose(zm.numpy(), z.numpy()[..., ::-1], atol=1e-6)
        own = z.argmax(-1).numpy() - 1  # the read-out's side given back: the same as side=None
        np.testing.assert_allclose(m.forward_aux(x, p, side=own)[0].detach().numpy(),
                                   m.forward_aux(x, p)[0].detach().numpy(), atol=1e-6)
        assert np.abs(m.forward_aux(x, p, side=-own)[0].numpy() - m.forward_aux(x, p)[0].numpy()).max() > 1e-4


def test_learner_step_by_step_is_the_whole_episode_forward(ds):
    from tin_swarm_env.training.imitation import collect
    from tin_swarm_env.training.recurrent_imitation import previous_actions
    from tin_swarm_env.policies.heads import categorical_classes

    old = load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0))  # the study's layout: a sign-flip mirror
    lay = tse.parallel_env(scenario=old, n_robots=3).layout
    classes = categorical_classes()
    m = ds.SideHeadGRU(lay.size, lay.mirror_signs(), classes, hidden=8, width=8, seed=2)
    d = collect(old, 1, 4, learner=ds.TorchLearner(m), teacher="apf_student", sequences=True, n_robots=3,
                max_cycles=15)
    q = d.sequences[0]
    with torch.no_grad():
        z = m.forward_aux(q.obs, previous_actions(q, len(q.obs), classes))[0].numpy()
    top2 = np.sort(z, axis=-1)[..., -2:]
    clear = top2[..., 1] - top2[..., 0] > 1e-4
    assert clear.sum() > 0.9 * clear.size
    np.testing.assert_array_equal(q.driven[clear], classes[z.argmax(-1)][clear].astype(np.float32))
