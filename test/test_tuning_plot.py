"""scripts/tuning_plot.py: the step response of docs/tuning.md, through the handler's core on the
virtual bus. The servo's clock moves a fixed step per loop, so the traces are in servo time and
the same on every host (no host timing in the assertions)."""
import importlib.util
import pathlib
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "scripts" / "tuning_plot.py"


@pytest.fixture(scope="module")
def tuning_plot():
    spec = importlib.util.spec_from_file_location("tuning_plot", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules["tuning_plot"] = module  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop("tuning_plot", None)


@pytest.fixture(scope="module")
def responses(tuning_plot):
    return [tuning_plot.step_response(gains, 0.5) for gains in (tuning_plot.FACTORY, tuning_plot.TUNED)]


def test_the_tuned_gains_get_there_sooner_without_overshoot(responses):
    factory, tuned = responses
    assert factory.trace[0][1] == pytest.approx(0.0, abs=0.2)  # from 0 deg
    for response in responses:
        assert response.trace[-1][1] == pytest.approx(45.0, abs=0.1)  # both get to 45 deg
        assert response.settle_s() is not None
    assert tuned.time_to(0.9) < factory.time_to(0.9)
    assert tuned.settle_s() <= factory.settle_s()
    assert tuned.overshoot_deg() <= max(factory.overshoot_deg(), 0.1)


def test_the_picture_is_written(tuning_plot, responses, tmp_path):
    out = tmp_path / "step.svg"
    tuning_plot.draw(responses, str(out))
    text = out.read_text(encoding="utf-8")
    assert text.lstrip().startswith("<?xml") and "<svg" in text
    assert "<path" in text


def test_the_docs_picture_is_there():
    assert (SCRIPT.parents[1] / "docs" / "img" / "tuning_step.svg").is_file()
