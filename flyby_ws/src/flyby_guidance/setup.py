from setuptools import find_packages, setup

package_name = 'flyby_guidance'

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
    description='Terminal approach, trajectory adjusting and thruster-restriction logic.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'flyby_guidance = flyby_guidance.guidance_node:main'
        ],
    },
)
