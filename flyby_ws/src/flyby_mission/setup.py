from setuptools import find_packages, setup

package_name = 'flyby_mission'

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
    description='The mission as a whole: supervisor, headless driver, launcher, summaries, campaigns, reports.',
    license='Apache-2.0',
    package_data={'flyby_mission': ['fault_table.yaml']},
    entry_points={
        'console_scripts': [
            'flyby_supervisor = flyby_mission.supervisor_node:main',
            'flyby_live_view = flyby_mission.live_view_node:main',
            'flyby_cam_monitor = flyby_mission.cam_monitor_node:main',
        ],
    },
)
