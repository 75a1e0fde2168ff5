from setuptools import setup

package_name = 'spacecraft_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=[package_name],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools', 'attitude-core'],
    zip_safe=True,
    maintainer='Attitude Stack Maintainers',
    maintainer_email='maintainers@attitude-stack.dev',
    description='Rigid-body spacecraft attitude simulator node',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rigid_body_sim = spacecraft_sim.sim_node:main',
        ],
    },
)
