from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class SampleMode(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    ASI: _ClassVar[SampleMode]
    RSI: _ClassVar[SampleMode]
    FSI: _ClassVar[SampleMode]

class Baseline(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    COMPONENT_MEAN: _ClassVar[Baseline]
    NONE: _ClassVar[Baseline]
ASI: SampleMode
RSI: SampleMode
FSI: SampleMode
COMPONENT_MEAN: Baseline
NONE: Baseline

class CreateJobRequest(_message.Message):
    __slots__ = ("job_id", "state_dim", "num_components", "phases", "initial_means_f64", "initial_stds_f64", "reference_states_f32", "reference_phases", "step_size", "episodes_per_update", "max_step_fraction", "min_std", "baseline", "update_rule", "fall_weighting")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    STATE_DIM_FIELD_NUMBER: _ClassVar[int]
    NUM_COMPONENTS_FIELD_NUMBER: _ClassVar[int]
    PHASES_FIELD_NUMBER: _ClassVar[int]
    INITIAL_MEANS_F64_FIELD_NUMBER: _ClassVar[int]
    INITIAL_STDS_F64_FIELD_NUMBER: _ClassVar[int]
    REFERENCE_STATES_F32_FIELD_NUMBER: _ClassVar[int]
    REFERENCE_PHASES_FIELD_NUMBER: _ClassVar[int]
    STEP_SIZE_FIELD_NUMBER: _ClassVar[int]
    EPISODES_PER_UPDATE_FIELD_NUMBER: _ClassVar[int]
    MAX_STEP_FRACTION_FIELD_NUMBER: _ClassVar[int]
    MIN_STD_FIELD_NUMBER: _ClassVar[int]
    BASELINE_FIELD_NUMBER: _ClassVar[int]
    UPDATE_RULE_FIELD_NUMBER: _ClassVar[int]
    FALL_WEIGHTING_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    state_dim: int
    num_components: int
    phases: _containers.RepeatedScalarFieldContainer[float]
    initial_means_f64: bytes
    initial_stds_f64: bytes
    reference_states_f32: bytes
    reference_phases: _containers.RepeatedScalarFieldContainer[float]
    step_size: float
    episodes_per_update: int
    max_step_fraction: float
    min_std: float
    baseline: Baseline
    update_rule: str
    fall_weighting: float
    def __init__(self, job_id: _Optional[str] = ..., state_dim: _Optional[int] = ..., num_components: _Optional[int] = ..., phases: _Optional[_Iterable[float]] = ..., initial_means_f64: _Optional[bytes] = ..., initial_stds_f64: _Optional[bytes] = ..., reference_states_f32: _Optional[bytes] = ..., reference_phases: _Optional[_Iterable[float]] = ..., step_size: _Optional[float] = ..., episodes_per_update: _Optional[int] = ..., max_step_fraction: _Optional[float] = ..., min_std: _Optional[float] = ..., baseline: _Optional[_Union[Baseline, str]] = ..., update_rule: _Optional[str] = ..., fall_weighting: _Optional[float] = ...) -> None: ...

class JobInfo(_message.Message):
    __slots__ = ("job_id", "version", "created", "state_dim", "num_components", "num_reference_frames")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    CREATED_FIELD_NUMBER: _ClassVar[int]
    STATE_DIM_FIELD_NUMBER: _ClassVar[int]
    NUM_COMPONENTS_FIELD_NUMBER: _ClassVar[int]
    NUM_REFERENCE_FRAMES_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    version: int
    created: bool
    state_dim: int
    num_components: int
    num_reference_frames: int
    def __init__(self, job_id: _Optional[str] = ..., version: _Optional[int] = ..., created: _Optional[bool] = ..., state_dim: _Optional[int] = ..., num_components: _Optional[int] = ..., num_reference_frames: _Optional[int] = ...) -> None: ...

class SampleRequest(_message.Message):
    __slots__ = ("job_id", "mode", "count", "seed")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    MODE_FIELD_NUMBER: _ClassVar[int]
    COUNT_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    mode: SampleMode
    count: int
    seed: int
    def __init__(self, job_id: _Optional[str] = ..., mode: _Optional[_Union[SampleMode, str]] = ..., count: _Optional[int] = ..., seed: _Optional[int] = ...) -> None: ...

class SampleReply(_message.Message):
    __slots__ = ("states_f32", "phases", "components", "frames", "version")
    STATES_F32_FIELD_NUMBER: _ClassVar[int]
    PHASES_FIELD_NUMBER: _ClassVar[int]
    COMPONENTS_FIELD_NUMBER: _ClassVar[int]
    FRAMES_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    states_f32: bytes
    phases: _containers.RepeatedScalarFieldContainer[float]
    components: _containers.RepeatedScalarFieldContainer[int]
    frames: _containers.RepeatedScalarFieldContainer[int]
    version: int
    def __init__(self, states_f32: _Optional[bytes] = ..., phases: _Optional[_Iterable[float]] = ..., components: _Optional[_Iterable[int]] = ..., frames: _Optional[_Iterable[int]] = ..., version: _Optional[int] = ...) -> None: ...

class ReportRequest(_message.Message):
    __slots__ = ("job_id", "initial_states_f32", "components", "returns", "policy_version", "fell")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    INITIAL_STATES_F32_FIELD_NUMBER: _ClassVar[int]
    COMPONENTS_FIELD_NUMBER: _ClassVar[int]
    RETURNS_FIELD_NUMBER: _ClassVar[int]
    POLICY_VERSION_FIELD_NUMBER: _ClassVar[int]
    FELL_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    initial_states_f32: bytes
    components: _containers.RepeatedScalarFieldContainer[int]
    returns: _containers.RepeatedScalarFieldContainer[float]
    policy_version: int
    fell: _containers.RepeatedScalarFieldContainer[bool]
    def __init__(self, job_id: _Optional[str] = ..., initial_states_f32: _Optional[bytes] = ..., components: _Optional[_Iterable[int]] = ..., returns: _Optional[_Iterable[float]] = ..., policy_version: _Optional[int] = ..., fell: _Optional[_Iterable[bool]] = ...) -> None: ...

class ReportReply(_message.Message):
    __slots__ = ("accepted", "version", "updated", "pending_episodes")
    ACCEPTED_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    UPDATED_FIELD_NUMBER: _ClassVar[int]
    PENDING_EPISODES_FIELD_NUMBER: _ClassVar[int]
    accepted: int
    version: int
    updated: bool
    pending_episodes: int
    def __init__(self, accepted: _Optional[int] = ..., version: _Optional[int] = ..., updated: _Optional[bool] = ..., pending_episodes: _Optional[int] = ...) -> None: ...

class GetDistributionRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class Distribution(_message.Message):
    __slots__ = ("means_f64", "stds_f64", "phases", "version", "pending_episodes", "state_dim", "num_components", "policy_version", "step_size", "episodes_per_update", "max_step_fraction", "min_std", "baseline", "update_rule", "component_weights", "fall_rates", "fall_weighting")
    MEANS_F64_FIELD_NUMBER: _ClassVar[int]
    STDS_F64_FIELD_NUMBER: _ClassVar[int]
    PHASES_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    PENDING_EPISODES_FIELD_NUMBER: _ClassVar[int]
    STATE_DIM_FIELD_NUMBER: _ClassVar[int]
    NUM_COMPONENTS_FIELD_NUMBER: _ClassVar[int]
    POLICY_VERSION_FIELD_NUMBER: _ClassVar[int]
    STEP_SIZE_FIELD_NUMBER: _ClassVar[int]
    EPISODES_PER_UPDATE_FIELD_NUMBER: _ClassVar[int]
    MAX_STEP_FRACTION_FIELD_NUMBER: _ClassVar[int]
    MIN_STD_FIELD_NUMBER: _ClassVar[int]
    BASELINE_FIELD_NUMBER: _ClassVar[int]
    UPDATE_RULE_FIELD_NUMBER: _ClassVar[int]
    COMPONENT_WEIGHTS_FIELD_NUMBER: _ClassVar[int]
    FALL_RATES_FIELD_NUMBER: _ClassVar[int]
    FALL_WEIGHTING_FIELD_NUMBER: _ClassVar[int]
    means_f64: bytes
    stds_f64: bytes
    phases: _containers.RepeatedScalarFieldContainer[float]
    version: int
    pending_episodes: int
    state_dim: int
    num_components: int
    policy_version: int
    step_size: float
    episodes_per_update: int
    max_step_fraction: float
    min_std: float
    baseline: Baseline
    update_rule: str
    component_weights: _containers.RepeatedScalarFieldContainer[float]
    fall_rates: _containers.RepeatedScalarFieldContainer[float]
    fall_weighting: float
    def __init__(self, means_f64: _Optional[bytes] = ..., stds_f64: _Optional[bytes] = ..., phases: _Optional[_Iterable[float]] = ..., version: _Optional[int] = ..., pending_episodes: _Optional[int] = ..., state_dim: _Optional[int] = ..., num_components: _Optional[int] = ..., policy_version: _Optional[int] = ..., step_size: _Optional[float] = ..., episodes_per_update: _Optional[int] = ..., max_step_fraction: _Optional[float] = ..., min_std: _Optional[float] = ..., baseline: _Optional[_Union[Baseline, str]] = ..., update_rule: _Optional[str] = ..., component_weights: _Optional[_Iterable[float]] = ..., fall_rates: _Optional[_Iterable[float]] = ..., fall_weighting: _Optional[float] = ...) -> None: ...
