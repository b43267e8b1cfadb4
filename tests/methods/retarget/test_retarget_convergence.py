"""The retargeting trainer stops on the convergence rule (1 % over the last 20 % of the
steps and at least one pass over the training samples), not on a wall budget, and says so."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

torch = pytest.importorskip("torch")

from dressmeup.methods.retarget.train import train_network  # noqa: E402


class _Sample:
    truth = None


class _Plateau:
    """A one-weight model whose loss falls to a floor of 1 (a plateau the rule must see)."""

    name, config = "plateau", SimpleNamespace(lr=0.05, seed=0)

    def new_network(self):
        torch.manual_seed(0)
        return torch.nn.Linear(1, 1)

    def loss(self, net, _sample):
        out = net(torch.ones(1, 1))
        total = ((out - 3.0) ** 2).sum() + 1.0
        return total, {"total": float(total.detach())}


def test_stops_when_converged_and_records_why():
    samples = [_Sample() for _ in range(4)]
    net, h = train_network(_Plateau(), samples, samples, steps=5000, val_every=10,
                           until_converged=True)
    assert h.stopped_by == "converged"
    assert len(h.train) < 5000
    last = [v for _, v, _ in h.val][-1]
    assert last == pytest.approx(1.0, abs=1e-2)


def test_the_rule_waits_for_one_pass_over_the_samples():
    """A plateau reached in the first steps does not stop a run before it has seen every
    training sample once."""
    samples = [_Sample() for _ in range(300)]
    _, h = train_network(_Plateau(), samples, samples[:2], steps=5000, val_every=10,
                         until_converged=True)
    assert h.stopped_by == "converged" and 300 <= len(h.train) < 5000


def test_runs_every_step_without_the_rule():
    samples = [_Sample() for _ in range(4)]
    _, h = train_network(_Plateau(), samples, samples, steps=120, val_every=10)
    assert h.stopped_by == "steps" and len(h.train) == 120


def test_the_rule_needs_validation():
    with pytest.raises(ValueError, match="validation"):
        train_network(_Plateau(), [_Sample()], None, steps=10, until_converged=True)
