"""End-to-end tests of build/bin/hapticd-query, the conformance runner, as a process:
one answer line per case line, in order, whatever the input; never a crash."""
import json
import math
import random
import subprocess

import pytest


def run_query(bin_dir, lines, timeout=120, backend="native"):
    proc = subprocess.run(
        [str(bin_dir / "hapticd-query"), "--ray-backend", backend],
        input="".join(line + "\n" for line in lines),
        capture_output=True, text=True, timeout=timeout,
    )
    assert proc.returncode == 0, proc.stderr
    return [json.loads(line) for line in proc.stdout.splitlines()]


def public_cases(shared_dir):
    cases = []
    for path in sorted((shared_dir / "conformance" / "public").glob("*.jsonl")):
        cases += [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return cases


def test_public_cases_pass_the_shared_checker(bin_dir, shared_dir):
    files = sorted(str(p) for p in (shared_dir / "conformance" / "public").glob("*.jsonl"))
    proc = subprocess.run(
        ["python3", str(shared_dir / "conformance" / "check.py"),
         "--runner", str(bin_dir / "hapticd-query"), *files],
        capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert proc.stdout.strip().splitlines()[-1].endswith(" 0 failed")


def test_truncated_cases_get_one_error_line_each(bin_dir, shared_dir):
    rng = random.Random(1)
    cases = rng.sample(public_cases(shared_dir), 300)
    lines = []
    for case in cases:
        text = json.dumps(case)
        lines.append(text[: rng.randrange(1, len(text) - 1)])
    answers = run_query(bin_dir, lines)
    assert len(answers) == len(lines)
    for answer in answers:
        assert answer["id"] is None
        assert answer["error"].startswith("malformed JSON at offset")


def numeric_leaves(value, path):
    """(path, container, key) of every number inside value, paths written as the runner does."""
    if isinstance(value, dict):
        items = [(f"{path}.{k}", k) for k in value]
    elif isinstance(value, list):
        items = [(f"{path}[{i}]", i) for i in range(len(value))]
    else:
        return []
    leaves = []
    for child_path, key in items:
        child = value[key]
        if isinstance(child, (int, float)) and not isinstance(child, bool):
            leaves.append((child_path, value, key))
        else:
            leaves += numeric_leaves(child, child_path)
    return leaves


def test_a_non_finite_number_anywhere_in_the_arguments_is_named(bin_dir, shared_dir):
    rng = random.Random(2)
    cases = [c for c in public_cases(shared_dir) if "error" not in c["expect"]]
    lines, ids, expected = [], [], []
    for case in rng.sample(cases, 300):
        path, container, key = rng.choice(numeric_leaves(case["args"], "args"))
        value = rng.choice([math.nan, math.inf, -math.inf])
        container[key] = value
        # json writes the bare tokens NaN, Infinity and -Infinity
        lines.append(json.dumps({"id": case["id"], "op": case["op"], "args": case["args"]}))
        ids.append(case["id"])
        token = json.dumps(value)
        # a mesh's triangle entries are vertex indices, not coordinates
        expected.append(f"{path} must be an integer index" if ".triangles[" in path
                        else f"{path} is {token}")
    answers = run_query(bin_dir, lines)
    assert [a["id"] for a in answers] == ids
    for answer, message in zip(answers, expected, strict=True):
        assert answer.get("error") == message, answer


@pytest.mark.parametrize("line", [
    "", "{", "null", "[]", '"text"', "{}", '{"id": "x"}', '{"id": "x", "op": "ray_triangle"}',
    '{"id": "x", "op": "ray_triangle", "args": []}',
    '{"id": "x", "op": "segment_mesh", "args": {"mesh": {"vertices": [], "triangles": []}, '
    '"p": [0,0,0], "q": [1,1,1]}}',
    "[" * 100000 + "]" * 100000,
    '{"id": "x", "op": "obb_obb", "args": {"a": {"center": [0,0,0], "rotation": 1e999}}}',
    "\x00\xff\xfe garbage",
])
def test_hostile_lines_get_error_answers(bin_dir, line):
    answers = run_query(bin_dir, [line, '{"id": "after", "op": "aabb_aabb", "args": '
                                        '{"a": {"min": [0,0,0], "max": [1,1,1]}, '
                                        '"b": {"min": [2,0,0], "max": [3,1,1]}}}'])
    if line.strip():
        assert len(answers) == 2
        assert "error" in answers[0] and "result" not in answers[0]
    # the runner goes on with the next line
    assert answers[-1] == {"id": "after", "result": {"intersect": False}}


def test_the_embree_backend_gives_the_native_answers(bin_dir, shared_dir):
    """Every public mesh case through both backends: the same hit, t, distance and
    inside answers (the triangle and the closest point may differ only where two tie,
    as on a medial axis)."""
    cases = [case for case in public_cases(shared_dir) if case["op"].endswith("_mesh")]
    assert len(cases) == 450
    lines = [json.dumps(case) for case in cases]
    native = run_query(bin_dir, lines, backend="native")
    embree = run_query(bin_dir, lines, backend="embree")
    for case, a, b in zip(cases, native, embree, strict=True):
        assert a.get("error") == b.get("error"), case["id"]
        ra, rb = a.get("result", {}), b.get("result", {})
        for key in ("hit", "t", "distance", "inside"):
            assert ra.get(key) == rb.get(key), (case["id"], key, ra, rb)


def test_an_unknown_backend_is_refused(bin_dir):
    proc = subprocess.run([str(bin_dir / "hapticd-query"), "--ray-backend", "optix"],
                          input="", capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2
    assert "--ray-backend native|embree" in proc.stderr
