"""The FastSLAM stack's wire contract for Python: ctypes structures with the
protocol's type names, sizes and alignments, and the topics' settings.

GENERATED from services/protocol/README.md by tests/bindings.rs: do not edit;
regenerate with FASTSLAM_BLESS=1 cargo test -p fastslam-protocol --test bindings.
Use with the iceoryx2 wheel (0.10): the structures carry `type_name()`.

A received slice sample's `len()` is its payload's size in bytes, not in elements:
take the element count from the user header (a map's `LandmarkMapHeader.count`,
an observation message's `ObservationsHeader.count`).
"""

import ctypes
from typing import NamedTuple

MAX_PUBLISHERS = 8
MAX_SUBSCRIBERS = 8


class Topic(NamedTuple):
    """A topic: service name below the prefix, subscriber buffer, history, payload."""

    name: str
    buffer: int
    history: int
    payload: str
    user_header: str


GROUND_TRUTH = Topic("ground_truth", 256, 0, "fastslam::GroundTruth", "")

TRUTH_LANDMARKS = Topic("truth/landmarks", 2, 1, "[fastslam::MapLandmark]", "fastslam::LandmarkMapHeader")

ODOMETRY = Topic("odometry", 256, 0, "fastslam::Odometry", "")

OBSERVATIONS = Topic("observations", 64, 0, "[fastslam::Observation]", "fastslam::ObservationsHeader")

SCAN = Topic("scan", 64, 0, "[f32] (ranges, then intensities)", "fastslam::LaserScanHeader")

POSE = Topic("pose", 256, 0, "fastslam::PoseEstimate", "")

MAP = Topic("map", 4, 1, "[fastslam::MapLandmark]", "fastslam::LandmarkMapHeader")

GRID = Topic("grid", 2, 1, "[i8] (cells)", "fastslam::OccupancyGridHeader")

SMOOTHED_TRAJECTORY = Topic("smoothed/trajectory", 2, 1, "[fastslam::TrajectoryPose]", "fastslam::TrajectoryHeader")

SMOOTHED_MAP = Topic("smoothed/map", 2, 1, "[fastslam::MapLandmark]", "fastslam::LandmarkMapHeader")

PARTICLES = Topic("particles", 16, 0, "[fastslam::Particle]", "fastslam::ParticlesHeader")

STATUS = Topic("status", 256, 1, "fastslam::ServiceStatus", "")

CHECKPOINT = Topic("checkpoint", 16, 1, "fastslam::Checkpointed", "")

END_OF_STREAM = Topic("end_of_stream", 16, 0, "fastslam::EndOfStream", "")

STREAM_GROUND_TRUTH = 1
STREAM_ODOMETRY = 2
STREAM_OBSERVATIONS = 3
STREAM_POSE = 4
STREAM_MAP = 5
STREAM_STATUS = 6
STREAM_SCAN = 7
STREAM_GRID = 8
STREAM_SMOOTHED_TRAJECTORY = 9
STREAM_SMOOTHED_MAP = 10
STREAM_PARTICLES = 11


class Header(ctypes.Structure):
    """The `header` of a message."""

    _fields_ = [
        ("stamp_ns", ctypes.c_uint64),  # ns
        ("seq", ctypes.c_uint64),  # —
    ]


class GroundTruth(ctypes.Structure):
    """`fastslam::GroundTruth` (64 bytes, alignment 8): true pose and the controls that led to it."""

    _fields_ = [
        ("header", Header),
        ("x", ctypes.c_double),  # m: position x, frame `map`
        ("y", ctypes.c_double),  # m: position y
        ("theta", ctypes.c_double),  # rad: heading in (−π, π]
        ("v", ctypes.c_double),  # m/s: true speed over the interval ending at the stamp
        ("omega", ctypes.c_double),  # rad/s: true yaw rate over that interval
        ("steering", ctypes.c_double),  # rad: true steering angle (0 for differential drive)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::GroundTruth"


class Odometry(ctypes.Structure):
    """`fastslam::Odometry` (64 bytes, alignment 8): odometry pose in `odom`; measured speed, yaw rate, steering."""

    _fields_ = [
        ("header", Header),
        ("v", ctypes.c_double),  # m/s: measured forward speed (0 when unknown)
        ("omega", ctypes.c_double),  # rad/s: measured yaw rate (differential drive; 0 when unknown)
        ("steering", ctypes.c_double),  # rad: measured steering angle (car-like)
        ("x", ctypes.c_double),  # m: odometry x, frame `odom`
        ("y", ctypes.c_double),  # m: odometry y
        ("theta", ctypes.c_double),  # rad: odometry heading
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::Odometry"


class ObservationsHeader(ctypes.Structure):
    """`fastslam::ObservationsHeader` (48 bytes, alignment 8): header of one scan's landmark observations."""

    _fields_ = [
        ("header", Header),
        ("count", ctypes.c_uint32),  # —: number of observations (= slice length)
        ("reserved", ctypes.c_uint32),  # —: 0
        ("max_range", ctypes.c_double),  # m: the sensor's maximum range
        ("min_bearing", ctypes.c_double),  # rad: smallest bearing the sensor covers
        ("max_bearing", ctypes.c_double),  # rad: largest bearing the sensor covers
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::ObservationsHeader"


class Observation(ctypes.Structure):
    """`fastslam::Observation` (32 bytes, alignment 8): one range–bearing observation."""

    _fields_ = [
        ("range", ctypes.c_double),  # m: range to the landmark's centre, in (0, max_range]
        ("bearing", ctypes.c_double),  # rad: bearing, vehicle frame
        ("diameter", ctypes.c_double),  # m: measured diameter, 0 when unknown
        ("id", ctypes.c_int64),  # —: landmark id when known (known association: 0 to 2²⁰ − 1, else the message is rejected as `out_of_range`), −1 otherwise
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::Observation"


class PoseEstimate(ctypes.Structure):
    """`fastslam::PoseEstimate` (112 bytes, alignment 8): estimated pose with 3×3 covariance."""

    _fields_ = [
        ("header", Header),
        ("x", ctypes.c_double),  # m: position x, frame `map`
        ("y", ctypes.c_double),  # m: position y
        ("theta", ctypes.c_double),  # rad: heading
        ("covariance", ctypes.c_double * 9),  # m², m·rad, rad²: covariance of (x, y, θ), row-major
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::PoseEstimate"


class LandmarkMapHeader(ctypes.Structure):
    """`fastslam::LandmarkMapHeader` (24 bytes, alignment 8): header of a landmark map."""

    _fields_ = [
        ("header", Header),
        ("count", ctypes.c_uint32),  # —: number of landmarks (= slice length)
        ("reserved", ctypes.c_uint32),  # —: 0
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::LandmarkMapHeader"


class MapLandmark(ctypes.Structure):
    """`fastslam::MapLandmark` (56 bytes, alignment 8): one landmark: mean and covariance."""

    _fields_ = [
        ("id", ctypes.c_uint64),  # —: stable id within the map
        ("x", ctypes.c_double),  # m: mean x, frame `map`
        ("y", ctypes.c_double),  # m: mean y
        ("cov_xx", ctypes.c_double),  # m²: covariance xx
        ("cov_xy", ctypes.c_double),  # m²: covariance xy
        ("cov_yy", ctypes.c_double),  # m²: covariance yy
        ("observations", ctypes.c_uint64),  # —: times observed (0 in a true map)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::MapLandmark"


class MapRequest(ctypes.Structure):
    """`fastslam::MapRequest` (8 bytes, alignment 8): a request for the current map (`map/get`)."""

    _fields_ = [
        ("reserved", ctypes.c_uint64),  # —: 0
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::MapRequest"


class StreamStatus(ctypes.Structure):
    """`fastslam::StreamStatus` (24 bytes, alignment 8): one input stream's state, an entry of the service's status."""

    _fields_ = [
        ("stream", ctypes.c_uint32),  # —: the stream id (`EndOfStream.stream`'s values); 0 in an unused entry
        ("queued", ctypes.c_uint32),  # —: inputs of the stream waiting in the service's queue
        ("last_input_ns", ctypes.c_uint64),  # ns: newest accepted stamp of the stream (0 before the first)
        ("quiet", ctypes.c_uint32),  # —: 1: quiet beyond its deadline, not waited for (odometry: scans are processed without prediction; the lidar: odometry keeps predicting); 0: heard from in time
        ("reserved", ctypes.c_uint32),  # —: 0
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::StreamStatus"


class ServiceStatus(ctypes.Structure):
    """`fastslam::ServiceStatus` (384 bytes, alignment 8): the service's filter health and input bookkeeping."""

    _fields_ = [
        ("header", Header),
        ("steps", ctypes.c_uint64),  # —: observation steps done
        ("resamplings", ctypes.c_uint64),  # —: times the particles were resampled
        ("n_eff", ctypes.c_double),  # —: effective sample size of the last step, before resampling
        ("particles", ctypes.c_uint32),  # —: number of particles
        ("distinct_particles", ctypes.c_uint32),  # —: distinct particles after the last step
        ("landmarks", ctypes.c_uint64),  # —: landmarks in the best particle's map
        ("step_time_ns", ctypes.c_uint64),  # ns: wall-clock time of the last filter update, sending its pose included (the pose goes out before the maps are updated, so it is seen earlier than this)
        ("flags", ctypes.c_uint32),  # —: bit 0: the last step resampled; bit 1: degraded (an input is quiet beyond its deadline: which one, `streams[k].quiet`); bit 4: final status, sent at shutdown (not a step); bit 5: noise check failed (NIS above its χ² band for a whole window); bit 6: with bit 5, the odometry noise is suspected, else the sensor's (the noise fit's verdict once warmed up, before it whether the pose term dominates the innovations); bit 7: the smoothing back-end's newest solve was torn and withheld (the smoothed topics hold an older solution, or none); bit 8: the landmark filter associates its observations without ids (unknown association), set on every status; bits 2 and 3 unused
        ("nis_dof", ctypes.c_uint32),  # —: degrees of freedom in the noise check's window (2 per matched observation)
        ("rejections", ctypes.c_uint64 * 16),  # —: rejected inputs by reason: 0 non-finite, 1 out of range, 2 bad count, 3 stamp backwards, 4 refused by the filter, 5 duplicate seq, 6 stamp jump, 7 teleporting odometry, 8 queue overflow (oldest dropped), 9 late (after a quiet stream), 10 lost (sent while the service was down, no longer kept by its sensor for the resumed service), 11 covered (skipped by a resumed service: its checkpoint already holds it; the input that begins a resend is not counted)
        ("nis", ctypes.c_double),  # —: noise check: NIS per degree of freedom over the last 50 scans, predicted from the motion prior (1 when the noise model fits; NaN before any match; docs/ALGORITHMS.md)
        ("stream_count", ctypes.c_uint32),  # —: entries of `streams` in use
        ("torn_solves", ctypes.c_uint32),  # —: solves of the smoothing back-end withheld as torn so far (docs/ALGORITHMS.md); 0 without a back-end
        ("streams", StreamStatus * 4),  # —: the service's input streams (odometry first, then the lidar), the first `stream_count` entries
        ("noise_profile", ctypes.c_double * 4),  # m/s or m/√m, rad/s or rad or rad/√rad, m, rad: the configured noise as standard deviations: the motion model's two (`sigma_v` and `sigma_omega` or `sigma_steering`; increment: `translation_per_m`, `rotation_per_rad`), `sigma_range`, `sigma_bearing` (0 without a noise fit)
        ("noise_fitted", ctypes.c_double * 4),  # as `noise_profile: the same four as fitted (docs/ALGORITHMS.md §1, "Noise fit"): by the smoothing back-end's variance components once it has solved the whole graph (§8.4), else from the innovations (the profile's until that fit has warmed up); 0 without a noise fit
        ("noise_fit", ctypes.c_uint32),  # —: where `noise_fitted` comes from: 0 no noise fit, 1 the filter's innovations, 2 the smoothing back-end's newest whole solve
        ("noise_suspect", ctypes.c_uint32),  # —: the source the noise check blames: 0 none, 1 the odometry, 2 the sensor. With `noise_fit` 2, the back-end's verdict (a group's variance at least twice the model's, the larger); else that of the failed NIS check (bits 5 and 6 of `flags`)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::ServiceStatus"


class StreamCovered(ctypes.Structure):
    """`fastslam::StreamCovered` (16 bytes, alignment 8): what a checkpoint holds of one input stream."""

    _fields_ = [
        ("stream", ctypes.c_uint32),  # —: the stream id (`EndOfStream.stream`'s values); 0 in an unused entry
        ("reserved", ctypes.c_uint32),  # —: 0
        ("covered_ns", ctypes.c_uint64),  # ns: stamp of the stream's last input the checkpoint holds
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::StreamCovered"


class Checkpointed(ctypes.Structure):
    """`fastslam::Checkpointed` (88 bytes, alignment 8): what the service's last checkpoint covers; a resumed service's request."""

    _fields_ = [
        ("header", Header),
        ("stream_count", ctypes.c_uint32),  # —: entries of `covered` in use
        ("resume", ctypes.c_uint32),  # —: 1: a resumed service asks for everything after `covered_ns`; 0: a checkpoint was written
        ("covered", StreamCovered * 4),  # —: per input stream, the stamp of the last input the checkpoint holds: the first `stream_count` entries
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::Checkpointed"


class ClientNotice(ctypes.Structure):
    """`fastslam::ClientNotice` (136 bytes, alignment 8): what the client has recorded; a restarted client's request."""

    _fields_ = [
        ("header", Header),
        ("restarts", ctypes.c_uint64),  # —: how many times the client recording this run was started again after it died
        ("recorded", ctypes.c_uint64 * 12),  # —: per stream (index: `EndOfStream.stream`'s value), the sequence number below which every message is recorded; for maps, grids and smoothed trajectories, one past the newest recorded
        ("ended", ctypes.c_uint64),  # —: bit `s` set: the end of stream `s` is recorded
        ("finished", ctypes.c_uint64),  # —: 1 once the client has written its run folder
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::ClientNotice"


class EndOfStream(ctypes.Structure):
    """`fastslam::EndOfStream` (24 bytes, alignment 8): "this stream is finished"."""

    _fields_ = [
        ("header", Header),
        ("stream", ctypes.c_uint32),  # —: 1 ground truth, 2 odometry, 3 observations, 4 pose, 5 map, 6 status, 7 scan, 8 grid, 9 smoothed trajectory, 10 smoothed map, 11 particles
        ("reserved", ctypes.c_uint32),  # —: 0
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::EndOfStream"


class LaserScanHeader(ctypes.Structure):
    """`fastslam::LaserScanHeader` (48 bytes, alignment 8): header of one raw lidar scan."""

    _fields_ = [
        ("header", Header),
        ("angle_min", ctypes.c_float),  # rad: direction of the first beam (0 = forward, counter-clockwise)
        ("angle_increment", ctypes.c_float),  # rad: angle between beams, > 0 (beams sweep counter-clockwise)
        ("time_increment", ctypes.c_float),  # s: time between beams, ≥ 0 (0: instantaneous scan)
        ("scan_time", ctypes.c_float),  # s: time between scans, ≥ 0
        ("range_min", ctypes.c_float),  # m: shortest measurable range
        ("range_max", ctypes.c_float),  # m: longest measurable range
        ("ranges", ctypes.c_uint32),  # —: number of ranges, 1..=65536
        ("intensities", ctypes.c_uint32),  # —: number of intensities after the ranges: 0 or `ranges`
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::LaserScanHeader"


class OccupancyGridHeader(ctypes.Structure):
    """`fastslam::OccupancyGridHeader` (56 bytes, alignment 8): header of an occupancy grid map."""

    _fields_ = [
        ("header", Header),
        ("resolution", ctypes.c_double),  # m: side of a square cell
        ("origin_x", ctypes.c_double),  # m: x of cell (0, 0)'s lower-left corner, frame `map`
        ("origin_y", ctypes.c_double),  # m: y of that corner
        ("origin_theta", ctypes.c_double),  # rad: rotation of the grid about its origin
        ("width", ctypes.c_uint32),  # —: cells per row (along x)
        ("height", ctypes.c_uint32),  # —: rows (along y)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::OccupancyGridHeader"


class TrajectoryHeader(ctypes.Structure):
    """`fastslam::TrajectoryHeader` (32 bytes, alignment 8): header of a smoothed trajectory."""

    _fields_ = [
        ("header", Header),
        ("count", ctypes.c_uint32),  # —: number of poses (= slice length)
        ("solves", ctypes.c_uint32),  # —: solves run so far, this one included
        ("chi2_per_dof", ctypes.c_double),  # —: χ² per degree of freedom at the solution (≈ 1 when the noise model and associations hold)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::TrajectoryHeader"


class TrajectoryPose(ctypes.Structure):
    """`fastslam::TrajectoryPose` (32 bytes, alignment 8): one pose of a trajectory."""

    _fields_ = [
        ("stamp_ns", ctypes.c_uint64),  # ns: stamp of the pose
        ("x", ctypes.c_double),  # m: position x, frame `map`
        ("y", ctypes.c_double),  # m: position y
        ("theta", ctypes.c_double),  # rad: heading
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::TrajectoryPose"


class ParticlesHeader(ctypes.Structure):
    """`fastslam::ParticlesHeader` (24 bytes, alignment 8): header of a particle cloud."""

    _fields_ = [
        ("header", Header),
        ("count", ctypes.c_uint32),  # —: number of particles (= slice length)
        ("reserved", ctypes.c_uint32),  # —: 0
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::ParticlesHeader"


class Particle(ctypes.Structure):
    """`fastslam::Particle` (32 bytes, alignment 8): one particle: pose and weight."""

    _fields_ = [
        ("x", ctypes.c_double),  # m: position x, frame `map`
        ("y", ctypes.c_double),  # m: position y
        ("theta", ctypes.c_double),  # rad: heading
        ("weight", ctypes.c_double),  # —: normalised weight, ≥ 0 (the cloud's weights sum to 1)
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 type name, as the Rust side declares it."""

        return "fastslam::Particle"


# The layouts above must equal the Rust ones (checked on import).
LAYOUTS = {
    GroundTruth: (64, 8, {"header": 0, "x": 16, "y": 24, "theta": 32, "v": 40, "omega": 48, "steering": 56}),
    Odometry: (64, 8, {"header": 0, "v": 16, "omega": 24, "steering": 32, "x": 40, "y": 48, "theta": 56}),
    ObservationsHeader: (48, 8, {"header": 0, "count": 16, "reserved": 20, "max_range": 24, "min_bearing": 32, "max_bearing": 40}),
    Observation: (32, 8, {"range": 0, "bearing": 8, "diameter": 16, "id": 24}),
    PoseEstimate: (112, 8, {"header": 0, "x": 16, "y": 24, "theta": 32, "covariance": 40}),
    LandmarkMapHeader: (24, 8, {"header": 0, "count": 16, "reserved": 20}),
    MapLandmark: (56, 8, {"id": 0, "x": 8, "y": 16, "cov_xx": 24, "cov_xy": 32, "cov_yy": 40, "observations": 48}),
    MapRequest: (8, 8, {"reserved": 0}),
    StreamStatus: (24, 8, {"stream": 0, "queued": 4, "last_input_ns": 8, "quiet": 16, "reserved": 20}),
    ServiceStatus: (384, 8, {"header": 0, "steps": 16, "resamplings": 24, "n_eff": 32, "particles": 40, "distinct_particles": 44, "landmarks": 48, "step_time_ns": 56, "flags": 64, "nis_dof": 68, "rejections": 72, "nis": 200, "stream_count": 208, "torn_solves": 212, "streams": 216, "noise_profile": 312, "noise_fitted": 344, "noise_fit": 376, "noise_suspect": 380}),
    StreamCovered: (16, 8, {"stream": 0, "reserved": 4, "covered_ns": 8}),
    Checkpointed: (88, 8, {"header": 0, "stream_count": 16, "resume": 20, "covered": 24}),
    ClientNotice: (136, 8, {"header": 0, "restarts": 16, "recorded": 24, "ended": 120, "finished": 128}),
    EndOfStream: (24, 8, {"header": 0, "stream": 16, "reserved": 20}),
    LaserScanHeader: (48, 8, {"header": 0, "angle_min": 16, "angle_increment": 20, "time_increment": 24, "scan_time": 28, "range_min": 32, "range_max": 36, "ranges": 40, "intensities": 44}),
    OccupancyGridHeader: (56, 8, {"header": 0, "resolution": 16, "origin_x": 24, "origin_y": 32, "origin_theta": 40, "width": 48, "height": 52}),
    TrajectoryHeader: (32, 8, {"header": 0, "count": 16, "solves": 20, "chi2_per_dof": 24}),
    TrajectoryPose: (32, 8, {"stamp_ns": 0, "x": 8, "y": 16, "theta": 24}),
    ParticlesHeader: (24, 8, {"header": 0, "count": 16, "reserved": 20}),
    Particle: (32, 8, {"x": 0, "y": 8, "theta": 16, "weight": 24}),
}
for _t, (_size, _align, _offsets) in LAYOUTS.items():
    assert ctypes.sizeof(_t) == _size, _t
    assert ctypes.alignment(_t) == _align, _t
    for _field, _offset in _offsets.items():
        assert getattr(_t, _field).offset == _offset, (_t, _field)
