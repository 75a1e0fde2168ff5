from glob import glob

from setuptools import setup

package_name = 'attitude_bringup'

setup(
    name=package_name,
    version='0.1.0',
    packages=[package_name],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
    ],
    install_requires=['setuptools', 'attitude-core', 'attitude-tools'],
    zip_safe=True,
    maintainer='Attitude Stack Maintainers',
    maintainer_email='maintainers@attitude-stack.dev',
    description='Recorder node and launch file of the attitude stack',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'bag_recorder = attitude_bringup.recorder_node:main',
            'lifecycle_manager = attitude_bringup.lifecycle_manager_node:main',
        ],
    },
)
