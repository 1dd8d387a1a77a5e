"""What the Python tests share: reading what a run wrote, and its finiteness
(nlohmann writes NaN and inf as null)."""
import json
import math


def read_json(path):
    """A JSON file's content (None if there is none, or it is not JSON)."""
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def finite_json(value):
    """No NaN, inf or null anywhere in a parsed JSON value."""
    if isinstance(value, dict):
        return all(finite_json(v) for v in value.values())
    if isinstance(value, list):
        return all(finite_json(v) for v in value)
    return value is not None and (not isinstance(value, float) or math.isfinite(value))


def all_finite(rows):
    """Every value of every row of a series.csv (csv.DictReader rows) is a finite number."""
    return all(math.isfinite(float(v)) for r in rows for v in r.values())
