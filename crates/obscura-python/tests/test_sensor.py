"""The image sensor from Python: the same keys as `obscura render --sensor`, the noisy processed
beauty beside the clean one (a training pair), the raw mosaic and the DNG."""

import numpy as np
import pytest

import obscura


def test_sensor_gives_a_training_pair_and_the_raw_planes(tmp_path):
    cam = obscura.Camera("PxrPerspective", format=(48, 32), fov=50)
    sensor = {"iso": 1600, "exposure_time_s": 0.0004, "cfa": "GRBG", "seed": 3}
    out = obscura.render(camera=cam, spp=4, sensor=sensor, raw_output=tmp_path / "r.dng")
    for name in ("beauty", "clean", "film"):
        assert out[name].shape == (32, 48, 3)
    assert out["raw"].shape == (32, 48) and out["electrons"].shape == (32, 48)
    # Raw codes are integers within the 12-bit ADC, at or above black where there is light.
    assert np.array_equal(out["raw"], np.round(out["raw"]))
    assert out["raw"].max() <= 4095
    # The pair differs by noise only: zero mean, and the noisy one varies more.
    diff = out["beauty"] - out["clean"]
    assert abs(float(diff.mean())) < 0.01
    assert float(diff.std()) > 0.005
    # Another seed draws other noise over the same clean image.
    again = obscura.render(camera=cam, spp=4, sensor=dict(sensor, seed=4))
    assert np.array_equal(again["clean"], out["clean"])
    assert not np.array_equal(again["beauty"], out["beauty"])
    dng = (tmp_path / "r.dng").read_bytes()
    assert dng[:4] == b"II*\x00"
    assert str(tmp_path / "r.dng") in out["stats"]["written"]


def test_without_a_sensor_the_outputs_are_the_film():
    cam = obscura.Camera("PxrPerspective", format=(16, 8), fov=50)
    out = obscura.render(camera=cam, spp=2)
    assert "raw" not in out and "clean" not in out


def test_bad_sensor_keys_are_named():
    cam = obscura.Camera("PxrPerspective", format=(8, 8), fov=50)
    with pytest.raises(ValueError, match='"bit_depth": expected an integer from 8 to 16, got 20'):
        obscura.render(camera=cam, spp=1, sensor={"bit_depth": 20})
