from setuptools import find_packages, setup

package_name = 'flyby_msgs_py'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={'flyby_msgs_py': ['config/*.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='flyby developers',
    maintainer_email='flyby@example.org',
    description=('The flyby interface contract and node infrastructure: topic names, QoS, frames, conversions, '
                 'markers, scenario schema engine, bag I/O, node runtime, recorder.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'flyby_recorder = flyby_msgs_py.recorder_node:main'
        ],
    },
)
