from setuptools import find_packages, setup

package_name = 'flyby_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='flyby developers',
    maintainer_email='flyby@example.org',
    description='Plant simulator: relative orbital dynamics, target attitude, thrusters, sensors, /clock.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'flyby_sim_node = flyby_sim.sim_node:main'
        ],
    },
)
