"""The layout keeps its promises: one direction of dependency, short functions, small modules.

Imports are read from the source (``ast``), counting imports inside functions and under
``if TYPE_CHECKING:``, so a cycle cannot hide behind a deferred import.
"""

from __future__ import annotations

import ast
import re
import warnings
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "hvacflex"
MAX_FUNCTION_LINES = 100
MAX_MODULE_LINES = 1000
"""A module holds one concept: past this it is more than one (the test fails)."""
WARN_MODULE_LINES = 800
"""Past this a module is getting large: the test warns, so the split is planned, not forced."""
MAX_CONTROL_PATH_MODULE_LINES = 600
"""The control path (``control/``, ``opt/``, ``sim/``) is read most: its modules stay below
this (issue 58; split by concept, not by line count)."""
CONTROL_PATH_PACKAGES = ("control", "opt", "sim")

LAYERS: list[set[str]] = [
    {
        "errors",
        "blas",
        "units",
        "constants",
        "dates",
        "paths",
        "tomlio",
        "version",
        "resources",
        "state",
    },
    {"results"},
    {"building"},
    {"data"},
    {"energyplus"},
    {"opt"},
    {"kpi", "meter_grade", "settlement"},
    {"config"},
    {"control"},
    {"sim"},
    {"identify"},
    {"validation"},
    {"report"},
    {
        "reproduce",
        "reproduce_plan",
        "reproduce_report",
        "reproduce_energyplus",
        "sensitivity",
        "robustness",
    },
    {"fleet", "service"},
    {"api", "simulation", "gym"},
    {"cli", "cli_config", "cli_help", "cli_model", "cli_serve", "cli_threads"},
    {"__main__"},
]
"""Bottom to top: a part may import its own layer's modules and the layers below it only."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                kept = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*kept, base] if base else kept)
            submodules = [f"{base}.{alias.name}" for alias in node.names]
            # ``from package import submodule`` depends on the submodule, not on the
            # package's ``__init__`` (which any submodule import initialises anyway)
            names_only = [s for s in submodules if s not in known]
            targets = [*submodules, *([base] if names_only else [])]
        found |= {t for t in targets if t in known and t != name}
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, set(modules)) for name, path in modules.items()}


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _layer(part: str) -> int:
    for level, members in enumerate(LAYERS):
        if part in members:
            return level
    raise AssertionError(f"module part {part!r} is not placed in a layer of {__name__}.LAYERS")


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one member (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_module_import_cycle() -> None:
    assert _cycles(_graph()) == []


def test_dependencies_point_down_the_layers() -> None:
    upward = sorted(
        f"{module} -> {target}"
        for module, targets in _graph().items()
        for target in targets
        if _part(module) and _part(target) and _layer(_part(target)) > _layer(_part(module))
    )
    assert upward == []


def test_cycle_finder_finds_a_cycle() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


@pytest.mark.parametrize(
    "path",
    sorted(path for package in CONTROL_PATH_PACKAGES for path in (PACKAGE / package).rglob("*.py")),
    ids=lambda p: str(p.relative_to(PACKAGE)),
)
def test_modules_of_the_control_path_are_short(path: Path) -> None:
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_CONTROL_PATH_MODULE_LINES, f"{lines} lines: split it by concept"


@pytest.mark.parametrize(
    "path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE))
)
def test_functions_and_modules_are_short(path: Path) -> None:
    source = path.read_text(encoding="utf-8")
    lines = len(source.splitlines())
    assert lines <= MAX_MODULE_LINES, f"{lines} lines: more than one concept, split it"
    if lines > WARN_MODULE_LINES:
        warnings.warn(f"{path.name}: {lines} lines (warn at {WARN_MODULE_LINES})", stacklevel=1)
    long_functions = [
        f"{node.name}: {node.end_lineno - node.lineno + 1} lines"
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno is not None
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert long_functions == []


TESTS = Path(__file__).resolve().parent

TEST_FILE_OF_ROOT = "test_api.py"
"""The root package's own code is the lazy public API, tested with :mod:`hvacflex.api`."""

MIRROR_EXEMPT_PREFIXES = ("hvacflex.service.migrations",)
"""Alembic's environment and revision scripts: run by the service's database tests
(``tests/service/test_service_api.py``), never imported as modules."""

WITHOUT_OWN_TEST_FILE: set[str] = {
    "hvacflex.building.channels",
    "hvacflex.building.io",
    "hvacflex.building.model",
    "hvacflex.building.plant",
    "hvacflex.config.model",
    "hvacflex.config.presets",
    "hvacflex.config.schema",
    "hvacflex.control.mpc",
    "hvacflex.control.prediction_error",
    "hvacflex.control.trajectory",
    "hvacflex.fleet.cli",
    "hvacflex.fleet.coordinate",
    "hvacflex.fleet.report",
    "hvacflex.opt.feedback_result",
    "hvacflex.opt.feedback_solve",
    "hvacflex.opt.options",
    "hvacflex.opt.solution",
    "hvacflex.opt.testing",
    "hvacflex.report.data_summary",
    "hvacflex.report.notes",
    "hvacflex.report.validation_plots",
    "hvacflex.service.app",
    "hvacflex.service.keys",
    "hvacflex.service.replay",
    "hvacflex.service.schemas",
    "hvacflex.sim.events",
    "hvacflex.sim.measurement",
    "hvacflex.sim.recording",
    "hvacflex.units",
    "hvacflex.validation.ideal_loads",
}
"""Today's modules without ``tests/<package>/test_<module>.py`` (grandfathered).

The list may only shrink: a module that gains its test file, or disappears, must leave it,
and a new module must come with its test file."""


def _own_test_file(module: str) -> Path | None:
    """Where a module's tests live: ``hvacflex.a.b`` → ``tests/a/test_b.py``,
    ``hvacflex.a`` → ``tests/test_a.py``. None for a package ``__init__`` that only
    documents and re-exports (no function or class of its own)."""
    if module == "hvacflex":
        return TESTS / TEST_FILE_OF_ROOT
    path = _modules()[module]
    if path.name == "__init__.py":
        tree = ast.parse(path.read_text(encoding="utf-8"))
        defines = (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)
        if not any(isinstance(node, defines) for node in tree.body):
            return None
    *package, name = module.split(".")[1:]
    return TESTS.joinpath(*package, f"test_{name}.py")


def _modules_to_mirror() -> dict[str, Path]:
    return {
        module: test_file
        for module in sorted(_modules())
        if not module.startswith(MIRROR_EXEMPT_PREFIXES)
        and (test_file := _own_test_file(module)) is not None
    }


def test_tests_mirror_the_package() -> None:
    """Every module has its own test file, but the grandfathered ones (a list that only
    shrinks: it must name exactly the modules without one)."""
    missing = {module for module, test in _modules_to_mirror().items() if not test.is_file()}
    new_without = sorted(missing - WITHOUT_OWN_TEST_FILE)
    assert new_without == [], "add tests/<package>/test_<module>.py for these modules"
    stale = sorted(WITHOUT_OWN_TEST_FILE - missing)
    assert stale == [], "these have a test file now or are gone: drop them from the list"


def test_the_mirror_rule_maps_modules_to_their_test_files() -> None:
    assert _own_test_file("hvacflex.building.rc") == TESTS / "building" / "test_rc.py"
    assert _own_test_file("hvacflex.kpi") == TESTS / "test_kpi.py"
    assert _own_test_file("hvacflex.config") == TESTS / "test_config.py"  # code in __init__
    assert _own_test_file("hvacflex.opt") is None  # re-exports only
    assert _own_test_file("hvacflex") == TESTS / "test_api.py"


MAX_CLASS_LINES = 400
"""A class in ``control/``, ``sim/`` or ``fleet/`` does one job: past this it does several."""

CLASS_SIZE_PACKAGES = ("control", "sim", "fleet")


def _classes(path: Path) -> list[ast.ClassDef]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [node for node in ast.walk(tree) if isinstance(node, ast.ClassDef)]


def test_classes_of_the_control_path_are_small() -> None:
    too_long = [
        f"{path.relative_to(SRC)}:{node.name} ({(node.end_lineno or 0) - node.lineno + 1} lines)"
        for package in CLASS_SIZE_PACKAGES
        for path in sorted((PACKAGE / package).rglob("*.py"))
        for node in _classes(path)
        if (node.end_lineno or 0) - node.lineno + 1 > MAX_CLASS_LINES
    ]
    assert too_long == [], f"classes over {MAX_CLASS_LINES} lines"


def test_the_controller_protocol_is_act_and_its_state() -> None:
    """``Controller`` is ``act(inputs) -> Action``, ``get_state``, ``set_state``: whatever a
    period needs arrives in its ``PeriodInputs``, nothing is told by side calls
    (no ``note_…`` method anywhere in the package)."""
    from hvacflex.control.base import Controller

    methods = {
        name
        for name, value in vars(Controller).items()
        if callable(value) and not name.startswith("_")
    }
    assert methods == {"act", "get_state", "set_state"}
    hints = Controller.act.__annotations__
    assert hints == {"inputs": "PeriodInputs", "return": "Action"}
    noted = [
        f"{path.relative_to(SRC)}:{node.lineno} {node.name}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.name.startswith("note_")
    ]
    assert noted == []


def _own_private_names(tree: ast.Module) -> set[str]:
    """The private names a module defines itself: its functions, classes and methods, and
    the attributes its code assigns (``self._x = …``, class-level ``_x = …``)."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return {name for name in names if name.startswith("_")}


def _outside_imports(tree: ast.Module) -> set[str]:
    """Names a module binds to other libraries' modules (``import typer``)."""
    return {
        (alias.asname or alias.name).split(".")[0]
        for node in tree.body
        if isinstance(node, ast.Import)
        for alias in node.names
        if not alias.name.startswith("hvacflex")
    }


def _foreign_private_accesses(name: str, path: Path) -> list[str]:
    """``x._attr`` where ``_attr`` is another module's private name and ``x`` is not
    ``self``/``cls``/``super()``: one part reaching into another part's private state. A
    module's own private names (its classes' attributes used on another instance) and
    other libraries' are not this rule's."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    own, outside = _own_private_names(tree), _outside_imports(tree)
    found: list[str] = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or not node.attr.startswith("_"):
            continue
        if node.attr.endswith("__") or node.attr in own:
            continue
        root = node.value
        while isinstance(root, ast.Attribute):
            root = root.value
        if isinstance(root, ast.Name) and root.id in ("self", "cls", *outside):
            continue
        if isinstance(root, ast.Call) and isinstance(root.func, ast.Name):
            if root.func.id == "super":
                continue
        found.append(f"{name}:{node.lineno} .{node.attr}")
    return found


def test_the_private_access_rule_finds_a_reach_into_another_part(tmp_path: Path) -> None:
    module = ast.parse("class A:\n    def f(self, b):\n        return b._solver, self._x\n")
    assert _own_private_names(module) == set()
    path = tmp_path / "probe.py"
    path.write_text("def f(controller):\n    return controller._solver\n", encoding="utf-8")
    assert _foreign_private_accesses("probe", path) == ["probe:2 ._solver"]


PRIVATE_ACCESS_ALLOWED: set[str] = set()
"""Modules allowed to read another object's private attributes (none)."""


def test_no_module_reaches_into_another_objects_private_attributes() -> None:
    """A part talks to another through its public names; ``obj._attr`` outside ``self`` is
    a test failure (the fleet's controller composes the MPC's parts, it does not reach into
    them)."""
    reached = [
        access
        for name, path in sorted(_modules().items())
        if name not in PRIVATE_ACCESS_ALLOWED
        for access in _foreign_private_accesses(name, path)
    ]
    assert reached == []


TIME_HOME = PACKAGE / "constants.py"
"""The one home of the market period and time zone (``PERIOD_S``, ``PERIOD``, ``PERIOD_FREQ``,
``PERIODS_PER_DAY``, ``TIMEZONE``)."""

TIME_LITERALS = re.compile(
    r"(=\s*1800(\.0)?(?![\d.])|=\s*48(?![\d.])|Timedelta\(minutes=30\)|\"30min\"|\"Asia/Singapore\")"
)
"""A literal definition of the period (1800 s, 48 a day, 30 min) or of the time zone."""


def test_the_period_and_the_time_zone_have_one_home() -> None:
    """Every module reads the period and the time zone from :mod:`hvacflex.constants`;
    a literal one elsewhere is a second home."""
    found = [
        f"{path.relative_to(SRC)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != TIME_HOME
        for number, line in _code_lines(path)
        if TIME_LITERALS.search(line)
    ]
    assert found == []


PERIOD_NUMBERS = re.compile(
    r"(?<![\w.])(48|1800)(?![\d.])|\bminutes\s*=\s*30\b|\bdt_h\s*(:\s*float)?\s*=\s*0\.5\b"
)
"""A period used as a bare number in code: 48 a day, 1800 s, 30 minutes, Δt = 0.5 h."""

STRING_LITERAL = re.compile(r"\"[^\"]*\"|'[^']*'")
"""A one-line string literal (messages may say "48 periods a day")."""


def test_the_period_is_read_not_repeated_as_a_number() -> None:
    """Code reads the period (and the periods in a day) from :mod:`hvacflex.constants`, not
    as a bare 48, 1800, ``minutes=30`` or a 0.5-hour Δt (prose and messages aside)."""
    found = [
        f"{path.relative_to(SRC)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != TIME_HOME
        for number, line in _code_lines(path)
        if PERIOD_NUMBERS.search(STRING_LITERAL.sub('""', line))
    ]
    assert found == []


def test_the_period_number_search_finds_each_form() -> None:
    for line in (
        "steps = round(days * 48)",
        "SAMPLING = timedelta(minutes=30)",
        "dt_h: float = 0.5",
    ):
        assert PERIOD_NUMBERS.search(STRING_LITERAL.sub('""', line)), line
    for line in ('hint="expected 48 rows per day"', "RESERVE_PRICE_SCALE = 48.5", "x = 1480"):
        assert not PERIOD_NUMBERS.search(STRING_LITERAL.sub('""', line)), line


def _code_lines(path: Path) -> list[tuple[int, str]]:
    """(number, text) of a module's lines outside docstrings and comments."""
    text = path.read_text(encoding="utf-8")
    prose: set[int] = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            if isinstance(node.value.value, str):
                prose.update(range(node.lineno, (node.end_lineno or node.lineno) + 1))
    return [
        (number, line)
        for number, line in enumerate(text.splitlines(), 1)
        if number not in prose and not line.lstrip().startswith("#")
    ]
