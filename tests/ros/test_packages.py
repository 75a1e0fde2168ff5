"""Structural checks for the ament_python ROS 2 packages under src/ (no colcon build)."""

import ast
import configparser
import os
import sys
import tomllib
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / 'src'
# Every ament package under src/ (a package.xml), found at run time: a new package is
# checked without editing this file.
PACKAGES = sorted(p.name for p in SRC.iterdir() if (p / 'package.xml').is_file())
# ROS packages of full installs only (no PyPI wheels): the launch file needs them.
FULL_INSTALL_ONLY = {'launch', 'launch_ros'}
# Pure pip packages in src/ (pyproject.toml, installed into .venv): colcon must skip them.
PIP_PACKAGES = ['attitude_core', 'attitude_tools']


def _parse(pkg):
    warnings = []
    package = parse_package(str(SRC / pkg / 'package.xml'), warnings=warnings)
    return package, warnings


def _setup_kwargs(pkg):
    """Literal keyword arguments of the setup() call in setup.py, resolving module-level names."""
    tree = ast.parse((SRC / pkg / 'setup.py').read_text())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    names[target.id] = node.value.value
    calls = [
        n
        for n in ast.walk(tree)
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == 'setup'
    ]
    assert len(calls) == 1, 'setup.py must call setup() exactly once'
    kwargs = {}
    for kw in calls[0].keywords:
        if isinstance(kw.value, ast.Constant):
            kwargs[kw.arg] = kw.value.value
        elif isinstance(kw.value, ast.Name) and kw.value.id in names:
            kwargs[kw.arg] = names[kw.value.id]
        else:
            kwargs[kw.arg] = kw.value
    return kwargs


@pytest.mark.parametrize('pkg', PACKAGES)
def test_package_xml_valid(pkg):
    package, warnings = _parse(pkg)
    assert warnings == []
    package.validate()  # raises InvalidPackage, e.g. on a malformed maintainer e-mail
    assert package.package_format == 3
    assert package.name == pkg
    assert package.get_build_type() == 'ament_python'
    assert package.version == '0.1.0'
    assert [lic for lic in package.licenses] == ['Apache-2.0']
    assert [m.email for m in package.maintainers] == ['maintainers@attitude-stack.dev']
    assert 'python3-pytest' in {d.name for d in package.test_depends}


@pytest.mark.parametrize('pkg', PACKAGES)
def test_package_xml_schema_line(pkg):
    text = (SRC / pkg / 'package.xml').read_text()
    assert 'href="http://download.ros.org/schema/package_format3.xsd"' in text


@pytest.mark.parametrize('pkg', PACKAGES)
def test_setup_py_matches_package_xml(pkg):
    package, _ = _parse(pkg)
    kwargs = _setup_kwargs(pkg)
    assert kwargs['name'] == pkg
    assert kwargs['version'] == package.version
    assert kwargs.get('zip_safe') is True
    assert 'tests_require' not in kwargs
    source = (SRC / pkg / 'setup.py').read_text()
    assert "'share/ament_index/resource_index/packages'" in source
    assert "'resource/' + package_name" in source
    assert "'share/' + package_name, ['package.xml']" in source


@pytest.mark.parametrize('pkg', PACKAGES)
def test_resource_marker_and_python_package(pkg):
    marker = SRC / pkg / 'resource' / pkg
    assert marker.is_file()
    init = SRC / pkg / pkg / '__init__.py'
    assert init.is_file()
    assert ast.get_docstring(ast.parse(init.read_text()))


@pytest.mark.parametrize('pkg', PACKAGES)
def test_setup_cfg_script_dirs(pkg):
    cfg = configparser.ConfigParser()
    assert cfg.read(SRC / pkg / 'setup.cfg')
    assert cfg.get('develop', 'script_dir') == f'$base/lib/{pkg}'
    assert cfg.get('install', 'install_scripts') == f'$base/lib/{pkg}'


@pytest.mark.parametrize('pkg', PACKAGES)
def test_colcon_identifies_ament_python(pkg):
    """colcon silently falls back to type 'python' if package.xml is rejected."""
    identification = pytest.importorskip('colcon_core.package_identification')
    desc = identification.identify(
        identification.get_package_identification_extensions(), SRC / pkg
    )
    assert desc is not None and desc is not False
    assert desc.type == 'ros.ament_python'
    assert desc.name == pkg


def test_workspace_src_symlink():
    link = ROOT / 'ros2_ws' / 'src'
    assert link.is_symlink()
    assert not Path(link.readlink()).is_absolute()
    assert link.resolve() == SRC.resolve()


@pytest.mark.parametrize('pkg', PACKAGES)
def test_exec_depends_are_known(pkg):
    """Each ROS exec_depend is in the workspace, in .venv's ament index or full-install only."""
    index = ROOT / '.venv' / 'share' / 'ament_index' / 'resource_index' / 'packages'
    if not index.is_dir():
        pytest.skip('.venv not bootstrapped')
    package, _ = _parse(pkg)
    unknown = [
        d.name
        for d in package.exec_depends
        if not d.name.startswith('python3-')
        and d.name not in FULL_INSTALL_ONLY
        and not (SRC / d.name / 'package.xml').is_file()
        and not (index / d.name).is_file()
    ]
    assert unknown == []


def _console_scripts(pkg):
    value = _setup_kwargs(pkg)['entry_points']
    return ast.literal_eval(value).get('console_scripts', [])


def test_attitude_ros_is_a_library():
    assert _console_scripts('attitude_ros') == []


@pytest.mark.parametrize('pkg', PIP_PACKAGES)
def test_colcon_skips_pip_packages(pkg):
    """attitude_core and attitude_tools are not ROS packages: colcon (which crawls every folder
    below ros2_ws/src) must identify none of their folders, or they need a COLCON_IGNORE."""
    identification = pytest.importorskip('colcon_core.package_identification')
    extensions = identification.get_package_identification_extensions()
    assert (SRC / pkg / 'pyproject.toml').is_file()
    assert not (SRC / pkg / 'package.xml').exists()
    if (SRC / pkg / 'COLCON_IGNORE').exists():
        return
    for dirpath, dirnames, _ in os.walk(SRC / pkg):
        dirnames[:] = [d for d in dirnames if not d.startswith('.') and d != '__pycache__']
        desc = identification.identify(extensions, Path(dirpath))
        assert not desc, f'colcon identifies {dirpath} as a package: add src/{pkg}/COLCON_IGNORE'


# --- exec_depends derived from the packages' real imports ------------------------------------
#
# Every .py file of an ament package (src/<pkg>/<pkg>/ and src/<pkg>/launch/) is parsed; each
# imported top-level module is classified at run time: the standard library (ignored), our pip
# packages (PIP_PACKAGES: not ROS packages, no rosdep key, installed by pip with their own
# requirements; never an exec_depend, as before), a ROS package (one of ours under src/, one
# in the ament index of .venv, or FULL_INSTALL_ONLY), or a system dependency (SYSTEM_KEYS).
# Each ROS package or system key imported must be an exec_depend, and each exec_depend must
# be imported, apart from the documented exceptions below.

AMENT_PACKAGES = PACKAGES
# Third-party modules that are not ROS packages: module name -> rosdep key.
SYSTEM_KEYS = {'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml'}
# Documented exceptions: package -> {exec_depend: why it is declared without being imported}.
EXEC_DEPEND_EXCEPTIONS: dict[str, dict[str, str]] = {}


def _contract_message_packages():
    from attitude_core.contract.topics import TOPICS

    return {t.type_name.split('/')[0] for t in TOPICS}


# Packages whose code imports modules by name at run time: package -> (what, modules).
DYNAMIC_IMPORTS = {
    'attitude_ros': (
        'contract.message_class() imports the message package of every topic of '
        'the contract (attitude_core.contract.topics.TOPICS), e.g. for the recorder',
        _contract_message_packages,
    ),
}


def _node_graph_packages():
    from attitude_core.config import node_graph

    return {spec.package for spec in node_graph.NODES}


# Launch files that start nodes of packages given by an expression, not a literal
# (``Node(package=spec.package)``): package -> (what, packages).
LAUNCHED_PACKAGES = {
    'attitude_bringup': (
        'the launch file starts one Node per entry of the node table '
        'attitude_core.config.node_graph.NODES',
        _node_graph_packages,
    ),
}


def _ament_indexes():
    rel = Path('share') / 'ament_index' / 'resource_index' / 'packages'
    return [d for d in {Path(sys.prefix) / rel, ROOT / '.venv' / rel} if d.is_dir()]


def _is_ros_package(name, indexes):
    return (
        name in FULL_INSTALL_ONLY
        or (SRC / name / 'package.xml').is_file()
        or any((index / name).is_file() for index in indexes)
    )


def _module_name(path, root):
    """Dotted module name of ``path`` below the import root ``root`` (None: not a module)."""
    if root is None:
        return None
    parts = list(path.relative_to(root).with_suffix('').parts)
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imports(path, root=None):
    """(absolute module names a file imports, whether it also imports dynamically).

    ``from a.b import c`` gives ``a.b`` and ``a.b.c`` (``c`` may be a module); relative
    imports are resolved against the file's package (``root`` is its import root)."""
    tree = ast.parse(path.read_text(encoding='utf-8'), filename=str(path))
    module = _module_name(path, root)
    package = (
        (module if path.name == '__init__.py' else module.rpartition('.')[0]) if module else None
    )
    names, dynamic = set(), False
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                assert package is not None, f'{path}: relative import outside a package'
                base = '.'.join(package.split('.')[: len(package.split('.')) - node.level + 1])
                base = f'{base}.{node.module}' if node.module else base
            else:
                base = node.module
            names.add(base)
            names.update(f'{base}.{alias.name}' for alias in node.names if alias.name != '*')
        elif isinstance(node, ast.Call):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, 'id', None)
            dynamic = dynamic or called in ('import_module', '__import__')
    return names, dynamic


def _pip_module_file(name):
    """Source file of a module of one of our pip packages (None: not one, or not a module)."""
    top, *rest = name.split('.')
    base = SRC / top / top / Path(*rest) if rest else SRC / top / top
    for candidate in (base.with_suffix('.py'), base / '__init__.py'):
        if top in PIP_PACKAGES and candidate.is_file():
            return candidate
    return None


def _reached_through_pip_packages(names):
    """Top-level non-stdlib modules imported, transitively, by the modules of our pip packages
    among ``names`` (package ``__init__`` files included: they run first)."""
    seen, todo, found = set(), list(names), set()
    while todo:
        parts = todo.pop().split('.')
        for i in range(1, len(parts) + 1):
            path = _pip_module_file('.'.join(parts[:i]))
            if path is None or path in seen:
                continue
            seen.add(path)
            imported, _ = _imports(path, SRC / parts[0])
            for name in imported:
                top = name.split('.')[0]
                if top in PIP_PACKAGES:
                    todo.append(name)
                elif top not in sys.stdlib_module_names:
                    found.add(top)
    return found


def _launch_started_packages(path):
    """(packages of the nodes a launch file starts as ``Node(package='...')`` and the like,
    whether some ``package=`` is an expression instead of a literal)."""
    tree = ast.parse(path.read_text(encoding='utf-8'), filename=str(path))
    values = [
        kw.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        for kw in node.keywords
        if kw.arg == 'package'
    ]
    literal = [v for v in values if isinstance(v, ast.Constant) and isinstance(v.value, str)]
    return {v.value for v in literal}, len(literal) < len(values)


def _dependencies(pkg, indexes):
    """(required exec_depends with where each comes from, exec_depends allowed as well)."""
    required, pip_modules, unknown, dynamic_seen = {}, set(), [], False
    sources = sorted((SRC / pkg / pkg).rglob('*.py'))
    launch_files = sorted((SRC / pkg / 'launch').glob('*.py'))
    assert sources, f'no Python sources under src/{pkg}/{pkg}/'
    for path in sources + launch_files:
        where = str(path.relative_to(SRC))
        names, dynamic = _imports(path, SRC / pkg if path in sources else None)
        if dynamic:
            assert pkg in DYNAMIC_IMPORTS, (
                f'{where} imports modules by name at run time: say which in DYNAMIC_IMPORTS'
            )
            what, modules = DYNAMIC_IMPORTS[pkg]
            names |= set(modules())
            where, dynamic_seen = f'{where} ({what})', True
        if path in launch_files:
            started, computed = _launch_started_packages(path)
            names |= started
            if computed:
                assert pkg in LAUNCHED_PACKAGES, (
                    f'{where} starts nodes of packages it computes: say which in LAUNCHED_PACKAGES'
                )
                what, packages = LAUNCHED_PACKAGES[pkg]
                names |= set(packages())
                where = f'{where} ({what})'
        for top in sorted({name.split('.')[0] for name in names}):
            if top == pkg or top in sys.stdlib_module_names:
                continue
            if top in PIP_PACKAGES:
                pip_modules |= {n for n in names if n.split('.')[0] == top}
            elif _is_ros_package(top, indexes):
                required.setdefault(top, where)
            elif top in SYSTEM_KEYS:
                required.setdefault(SYSTEM_KEYS[top], where)
            else:
                unknown.append(f'{top} ({where})')
    assert not unknown, (
        f'src/{pkg}: imports neither ROS packages nor known system packages: '
        f'{unknown}; add their rosdep keys to SYSTEM_KEYS'
    )
    assert dynamic_seen or pkg not in DYNAMIC_IMPORTS, (
        f'DYNAMIC_IMPORTS[{pkg!r}] is stale: src/{pkg} imports nothing by name any more'
    )
    # Our pip packages are installed by pip with their own requirements, so what they import is
    # not required here; a package may still declare it (rosdep then installs it on a full ROS
    # install), as long as the pip modules it imports really import it.
    reached = _reached_through_pip_packages(pip_modules)
    allowed = {SYSTEM_KEYS[m] for m in reached if m in SYSTEM_KEYS}
    allowed |= {m for m in reached if _is_ros_package(m, indexes)}
    return required, allowed


@pytest.mark.parametrize('pkg', AMENT_PACKAGES)
def test_exec_depends_match_the_imports(pkg):
    indexes = _ament_indexes()
    if not indexes:
        pytest.skip('.venv not bootstrapped (no ament index to tell ROS packages apart)')
    package, _ = _parse(pkg)
    declared = {d.name for d in package.exec_depends}
    required, allowed = _dependencies(pkg, indexes)
    exceptions = EXEC_DEPEND_EXCEPTIONS.get(pkg, {})
    missing = {dep: where for dep, where in required.items() if dep not in declared}
    assert not missing, (
        f'src/{pkg}/package.xml lacks exec_depends (dependency: imported in): {missing}'
    )
    unused = sorted(declared - set(required) - allowed - set(exceptions))
    assert not unused, (
        f'src/{pkg}/package.xml: exec_depends imported nowhere in the package: '
        f'{unused} (remove them, or document why in EXEC_DEPEND_EXCEPTIONS)'
    )
    stale = sorted(set(exceptions) - declared)
    assert not stale, f'EXEC_DEPEND_EXCEPTIONS[{pkg!r}] names undeclared dependencies: {stale}'


def test_pip_check_is_clean_in_the_venv():
    """Every installed distribution's requirements are met (an editable package that names
    a dependency by a distribution name nobody installs shows up here)."""
    import subprocess

    proc = subprocess.run(
        [sys.executable, '-m', 'pip', 'check', '--disable-pip-version-check'],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


# --- install_requires names the pip packages imported -----------------------------------------
#
# Our pip packages (PIP_PACKAGES) are no ROS packages, so package.xml cannot declare them;
# setup.py's install_requires does, by their distribution names (src/<pkg>/pyproject.toml).


def _pip_distribution(pip_package):
    project = tomllib.loads((SRC / pip_package / 'pyproject.toml').read_text())['project']
    return canonicalize_name(project['name'])


def _pip_packages_imported(pkg):
    """Our pip packages that the package's modules and launch files import."""
    sources = sorted((SRC / pkg / pkg).rglob('*.py'))
    launch_files = sorted((SRC / pkg / 'launch').glob('*.py'))
    found = set()
    for path in sources + launch_files:
        names, _ = _imports(path, SRC / pkg if path in sources else None)
        found |= {n.split('.')[0] for n in names} & set(PIP_PACKAGES)
    return found


def _install_requires(pkg):
    value = _setup_kwargs(pkg).get('install_requires', [])
    requires = ast.literal_eval(value) if isinstance(value, ast.AST) else value
    return {canonicalize_name(Requirement(r).name) for r in requires}


def test_the_pip_import_finder_sees_the_bringup_timeline():
    """attitude_bringup.timeline writes the bag with attitude_tools."""
    assert _pip_packages_imported('attitude_bringup') == {'attitude_core', 'attitude_tools'}
    assert _pip_distribution('attitude_tools') == 'attitude-tools'


@pytest.mark.parametrize('pkg', AMENT_PACKAGES)
def test_install_requires_names_each_pip_package_imported(pkg):
    ours = {_pip_distribution(p) for p in PIP_PACKAGES}
    imported = {_pip_distribution(p) for p in _pip_packages_imported(pkg)}
    declared = _install_requires(pkg) & ours
    assert imported <= declared, (
        f'src/{pkg}/setup.py: install_requires lacks {sorted(imported - declared)} '
        '(imported by the package)'
    )
    assert declared <= imported, (
        f'src/{pkg}/setup.py: install_requires names {sorted(declared - imported)}, '
        'which the package does not import'
    )
