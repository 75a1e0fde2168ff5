"""Structural checks for the ament_python ROS 2 packages under src/ (no colcon build)."""

import ast
import configparser
import os
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / 'src'
NODE_PACKAGES = ['attitude_planner', 'attitude_controller', 'spacecraft_sim']
PACKAGES = NODE_PACKAGES + ['attitude_ros', 'attitude_bringup']
NODE_EXEC_DEPENDS = {'rclpy', 'std_msgs', 'geometry_msgs', 'rosgraph_msgs', 'python3-numpy',
                     'python3-scipy'}
EXEC_DEPENDS = {
    **{pkg: NODE_EXEC_DEPENDS for pkg in NODE_PACKAGES},
    # library of the nodes: messages, parameters, time; no scipy
    'attitude_ros': {'rclpy', 'rcl_interfaces', 'std_msgs', 'geometry_msgs', 'rosgraph_msgs',
                     'builtin_interfaces', 'python3-numpy'},
    # recorder node and launch file: the node packages it starts, launch
    'attitude_bringup': {'rclpy', 'attitude_ros', 'attitude_planner', 'attitude_controller',
                         'spacecraft_sim', 'launch', 'launch_ros'},
}
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
    calls = [n for n in ast.walk(tree)
             if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == 'setup']
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
    assert EXEC_DEPENDS[pkg] <= {d.name for d in package.exec_depends}
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
        identification.get_package_identification_extensions(), SRC / pkg)
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
    unknown = [d.name for d in package.exec_depends
               if not d.name.startswith('python3-')
               and d.name not in FULL_INSTALL_ONLY
               and not (SRC / d.name / 'package.xml').is_file()
               and not (index / d.name).is_file()]
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
