"""What the Python test drivers share: named checks that are counted, and the
finiteness of what a run wrote (nlohmann writes NaN and inf as null)."""
import math

failures = []


def check(condition, message):
    """Print ok/FAIL with the message; a failure is counted, the driver goes on."""
    print(("ok    " if condition else "FAIL  ") + message, flush=True)
    if not condition:
        failures.append(message)


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
