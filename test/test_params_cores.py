"""Every core takes one typed, frozen parameter record (flyby_msgs_py.params) derived from the scenario schema."""

from pathlib import Path


def _planner_scenarios():
    """Every shipped scenario as single-chaser views (each chaser of a ``chasers:`` scenario its own)."""
    from flyby_sim.scenario import load_scenario

    for path in sorted((Path(__file__).resolve().parents[1] / 'scenarios').glob('*.yaml')):
        scenario = load_scenario(path)
        yield from ([scenario.for_chaser(n) for n in scenario.chaser_names] if scenario.chaser_names else [scenario])


def test_the_planner_core_takes_its_params_record_built_from_every_shipped_scenario():
    """PlannerCore's first parameter is its PlannerParams record (no Scenario); the record of every shipped chaser
    builds, with planner.offset_m the same in each method's sub-record; every key it reads is a schema key or a
    quantity the Scenario derives."""
    import inspect

    from flyby_msgs_py import params
    from flyby_planner.params import PlannerParams
    from flyby_planner.planner_core import PlannerCore
    from flyby_sim.scenario import SCHEMA, Scenario

    first = list(inspect.signature(PlannerCore.__init__).parameters.values())[1]
    assert first.annotation is PlannerParams and params.is_record(PlannerParams)
    for scenario in _planner_scenarios():
        p = PlannerParams.from_scenario(scenario)
        assert p.flyby.offset_m == p.optimal.offset_m == p.sync.offset_m == scenario.planner.offset_m
    for field, path in params.keys_of(PlannerParams):
        assert params.schema_field(SCHEMA, path) is not None or hasattr(Scenario, path), (field, path)


def _supervisor_and_plant_scenarios():
    """Every shipped scenario as single-chaser views (each chaser of a ``chasers:`` scenario its own)."""
    from flyby_sim.scenario import load_scenario

    for path in sorted((Path(__file__).resolve().parents[1] / 'scenarios').glob('*.yaml')):
        scenario = load_scenario(path)
        yield from ([scenario.for_chaser(n) for n in scenario.chaser_names] if scenario.chaser_names else [scenario])


def test_the_supervisor_core_and_the_plant_take_their_records_built_from_every_shipped_scenario():
    """SupervisorCore's first parameter is its SupervisorParams record, the Plant's its PlantConfig (sub-records: the
    thrusters, the rigid-body chaser and its IMU, the arm); the record of every shipped chaser builds and its core
    starts from it; every key they read is a schema key or a quantity the Scenario derives."""
    import inspect

    from flyby_mission.supervisor import SupervisorCore, SupervisorParams
    from flyby_msgs_py import params
    from flyby_sim.plant import Plant, PlantConfig
    from flyby_sim.scenario import SCHEMA, Scenario

    for core, record in ((SupervisorCore, SupervisorParams), (Plant, PlantConfig)):
        first = list(inspect.signature(core.__init__).parameters.values())[1]
        assert first.annotation is record and params.is_record(record), core
        for field, path in params.keys_of(record):
            assert params.schema_field(SCHEMA, path) is not None or hasattr(Scenario, path), (record, field, path)
    for scenario in _supervisor_and_plant_scenarios():
        supervisor = SupervisorCore(SupervisorParams.from_scenario(scenario))
        assert supervisor.params.offset_m == scenario.planner.offset_m
        config = PlantConfig.from_scenario(scenario)
        assert (config.chaser_body is not None) == (scenario.chaser.model == 'rigid_body')
        assert (config.grasp is not None) == (scenario.post_capture is not None)
        Plant(config)


def _guidance_scenarios():
    """Every shipped scenario as single-chaser views (each chaser of a ``chasers:`` scenario its own)."""
    from flyby_sim.scenario import load_scenario

    for path in sorted((Path(__file__).resolve().parents[1] / 'scenarios').glob('*.yaml')):
        scenario = load_scenario(path)
        yield from ([scenario.for_chaser(n) for n in scenario.chaser_names] if scenario.chaser_names else [scenario])


def test_the_guidance_core_takes_its_params_record_built_from_every_shipped_scenario():
    """GuidanceCore's first parameter is its GuidanceParams record (no Scenario), a sub-record per mode and None for
    a mode the scenario does not fly; the record of every shipped chaser builds and the core starts from it; every key
    it reads is a schema key or a quantity the Scenario derives."""
    import inspect

    from flyby_guidance.guidance_core import GuidanceCore
    from flyby_guidance.params import GuidanceParams
    from flyby_msgs_py import params
    from flyby_sim.scenario import SCHEMA, Scenario

    first = list(inspect.signature(GuidanceCore.__init__).parameters.values())[1]
    assert first.annotation is GuidanceParams and params.is_record(GuidanceParams)
    for field, path in params.keys_of(GuidanceParams):
        assert params.schema_field(SCHEMA, path) is not None or hasattr(Scenario, path), (field, path)
    for scenario in _guidance_scenarios():
        p = GuidanceParams.from_scenario(scenario)
        rigid = scenario.chaser.model == 'rigid_body'
        assert (p.chaser is not None) == (p.tracking is not None) == (p.synchronized is not None) == rigid
        assert (p.damping is not None) == (rigid and scenario.post_capture is not None)
        assert (p.transport is not None) == (p.damping is not None and scenario.post_capture.transport is not None)
        GuidanceCore(p)


def _estimator_scenarios():
    """Every shipped scenario as single-chaser views (each chaser of a ``chasers:`` scenario its own)."""
    from flyby_sim.scenario import load_scenario

    for path in sorted((Path(__file__).resolve().parents[1] / 'scenarios').glob('*.yaml')):
        scenario = load_scenario(path)
        yield from ([scenario.for_chaser(n) for n in scenario.chaser_names] if scenario.chaser_names else [scenario])


def test_the_estimator_core_takes_its_params_record_built_from_every_shipped_scenario():
    """EstimatorCore's first parameter is its EstimatorParams record (no Scenario), a sub-record per filter and None
    for a part the scenario does not run; the record of every shipped chaser builds and the core starts from it;
    every key it reads is a schema key or a quantity the Scenario derives."""
    import inspect

    from flyby_estimation.estimator_core import EstimatorCore
    from flyby_estimation.params import EstimatorParams
    from flyby_msgs_py import params
    from flyby_sim.scenario import SCHEMA, Scenario

    first = list(inspect.signature(EstimatorCore.__init__).parameters.values())[1]
    assert first.annotation is EstimatorParams and params.is_record(EstimatorParams)
    for field, path in params.keys_of(EstimatorParams):
        assert params.schema_field(SCHEMA, path) is not None or hasattr(Scenario, path), (field, path)
    for scenario in _estimator_scenarios():
        p = EstimatorParams.from_scenario(scenario)
        rigid = scenario.chaser.model == 'rigid_body'
        assert (p.chaser_attitude is not None) == rigid
        assert (p.mass_estimation is not None) == (rigid and scenario.post_capture is not None)
        assert (p.transport is not None) == (p.mass_estimation is not None
                                             and scenario.post_capture.transport is not None)
        core = EstimatorCore(p)
        assert core.target.config.gate_probability == core.nav.config.gate_probability == \
            scenario.estimation.gate_probability
