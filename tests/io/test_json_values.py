import json
import math

import numpy as np

from visnav.io.json_values import jsonable


def test_numpy_values_and_non_finite_numbers_become_plain_json():
    x = {"a": np.float32(1.5), "b": np.int64(3), "c": np.bool_(True), "d": float("nan"), "e": -math.inf,
         "f": np.array([[1.0, np.nan], [2.0, 3.0]]), "g": (np.float64(0.25), "s", None), "h": True}
    y = jsonable(x)
    assert y == {"a": 1.5, "b": 3, "c": True, "d": None, "e": None, "f": [[1.0, None], [2.0, 3.0]],
                 "g": [0.25, "s", None], "h": True}
    assert type(y["b"]) is int and type(y["c"]) is bool and type(y["h"]) is bool
    assert json.loads(json.dumps(y, allow_nan=False)) == y  # strict JSON: no NaN / Infinity tokens
