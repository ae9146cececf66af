from setuptools import find_packages, setup

package_name = 'flyby_planner'

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
    description='Capture planning: the fly-by, optimization-based, synchronized and transport methods.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'flyby_planner = flyby_planner.planner_node:main',
        ],
    },
)
