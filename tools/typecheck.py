"""The type check of CI: mypy as pyproject.toml configures it, and the allow-list audit.

1. ``mypy`` as configured ([tool.mypy] in pyproject.toml) must report no error.
2. ``mypy`` again with the allow-list switched off (the one ``[[tool.mypy.overrides]]``
   block with ``ignore_errors = true``, if any: it is empty now, and a module that
   cannot be typed yet goes there): every allow-listed module must still have an
   error, else it is named and must leave the allow-list, which only shrinks.

Run from anywhere: ``python tools/typecheck.py``. Exit status 0 when both hold.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = ROOT / "pyproject.toml"
_ERROR = re.compile(r"^(?P<path>[^:\s]+\.pyi?):\d+(?::\d+)?: error: ", re.MULTILINE)
_CHECKED = re.compile(r"(?:checked|in) (\d+) source files?")


def allow_list(config: dict) -> list[str]:
    """The allow-listed modules: the one override block with ``ignore_errors = true``."""
    blocks = [
        block
        for block in config.get("tool", {}).get("mypy", {}).get("overrides", [])
        if block.get("ignore_errors") is True
    ]
    if len(blocks) > 1:
        raise SystemExit("typecheck: pyproject.toml has more than one ignore_errors block")
    if not blocks:
        return []
    module = blocks[0]["module"]
    return [module] if isinstance(module, str) else list(module)


def without_allow_list(text: str) -> str:
    """pyproject.toml's text with the allow-list's ``ignore_errors = true`` made false."""
    lines = text.splitlines(keepends=True)
    hits = [i for i, line in enumerate(lines) if re.match(r"\s*ignore_errors\s*=\s*true", line)]
    if len(hits) != 1:
        raise SystemExit("typecheck: expected one 'ignore_errors = true' line in pyproject.toml")
    lines[hits[0]] = "ignore_errors = false\n"
    return "".join(lines)


def mypy(config_file: Path) -> tuple[int, str]:
    """mypy's exit status and its report, run in the repository root with ``config_file``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT / "src"), env.get("PYTHONPATH")]))
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(config_file), "--no-pretty"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
    )
    return run.returncode, run.stdout + run.stderr


def module_of(path: str) -> str:
    """``src/follicle/io/usd.py`` → ``follicle.io.usd``; a package's __init__ → the package."""
    parts = list(Path(path).with_suffix("").parts)
    if "src" in parts:
        parts = parts[parts.index("src") + 1 :]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def listed(module: str, patterns: list[str]) -> str | None:
    """The allow-list entry covering ``module`` (``a.b`` or ``a.b.*``), if any."""
    for pattern in patterns:
        if pattern == module or (
            pattern.endswith(".*") and (module == pattern[:-2] or module.startswith(pattern[:-1]))
        ):
            return pattern
    return None


def main() -> int:
    text = PYPROJECT.read_text(encoding="utf-8")
    allowed = allow_list(tomllib.loads(text))

    status, report = mypy(PYPROJECT)
    if status != 0:
        sys.stdout.write(report)
        print("typecheck: mypy reports errors (above): fix them; the allow-list only shrinks")
        return 1
    checked = _CHECKED.search(report)
    if not allowed:  # every module is checked: nothing to audit
        print(f"typecheck: {checked[1] if checked else '?'} modules checked, no errors")
        return 0

    with tempfile.TemporaryDirectory() as tmp:
        bare = Path(tmp) / "pyproject.toml"
        bare.write_text(without_allow_list(text), encoding="utf-8")
        _, full = mypy(bare)
    if "error: " in full and not _ERROR.search(full):
        sys.stdout.write(full)
        print("typecheck: mypy failed without the allow-list (above)")
        return 1

    errors: dict[str, int] = {pattern: 0 for pattern in allowed}
    for match in _ERROR.finditer(full):
        module = module_of(match["path"])
        pattern = listed(module, allowed)
        if pattern is None:  # cannot happen: the first run was clean
            sys.stdout.write(full)
            print(f"typecheck: {module} has errors without the allow-list but is not on it")
            return 1
        errors[pattern] += 1

    clean = [pattern for pattern, count in errors.items() if count == 0]
    for pattern in clean:
        print(
            f"typecheck: {pattern} has no type errors now:"
            " remove it from the allow-list in pyproject.toml"
        )
    print(
        f"typecheck: {checked[1] if checked else '?'} modules checked, no errors;"
        f" {len(allowed)} allow-listed, with {sum(errors.values())} errors in them"
    )
    return 1 if clean else 0


if __name__ == "__main__":
    sys.exit(main())
