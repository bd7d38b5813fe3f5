/* The FastSLAM stack's wire contract for C and C++ (C11).
 * GENERATED from services/protocol/README.md by tests/bindings.rs: do not edit;
 * regenerate with FASTSLAM_BLESS=1 cargo test -p fastslam-protocol --test bindings.
 * Publish with iceoryx2's C/C++ bindings: the type name, size and alignment of the
 * payload must be the ones below; every topic is a publish-subscribe and an event
 * service named <prefix>/<topic>, safe overflow off, the buffer and history below. */
#ifndef FASTSLAM_PROTOCOL_H
#define FASTSLAM_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#define FASTSLAM_MAX_PUBLISHERS 8
#define FASTSLAM_MAX_SUBSCRIBERS 8

/* ground_truth: payload fastslam::GroundTruth, user header none */
#define FASTSLAM_TOPIC_GROUND_TRUTH "ground_truth"
#define FASTSLAM_TOPIC_GROUND_TRUTH_BUFFER 256
#define FASTSLAM_TOPIC_GROUND_TRUTH_HISTORY 0

/* truth/landmarks: payload [fastslam::MapLandmark], user header fastslam::LandmarkMapHeader */
#define FASTSLAM_TOPIC_TRUTH_LANDMARKS "truth/landmarks"
#define FASTSLAM_TOPIC_TRUTH_LANDMARKS_BUFFER 2
#define FASTSLAM_TOPIC_TRUTH_LANDMARKS_HISTORY 1

/* odometry: payload fastslam::Odometry, user header none */
#define FASTSLAM_TOPIC_ODOMETRY "odometry"
#define FASTSLAM_TOPIC_ODOMETRY_BUFFER 256
#define FASTSLAM_TOPIC_ODOMETRY_HISTORY 0

/* observations: payload [fastslam::Observation], user header fastslam::ObservationsHeader */
#define FASTSLAM_TOPIC_OBSERVATIONS "observations"
#define FASTSLAM_TOPIC_OBSERVATIONS_BUFFER 64
#define FASTSLAM_TOPIC_OBSERVATIONS_HISTORY 0

/* scan: payload [f32] (ranges, then intensities), user header fastslam::LaserScanHeader */
#define FASTSLAM_TOPIC_SCAN "scan"
#define FASTSLAM_TOPIC_SCAN_BUFFER 64
#define FASTSLAM_TOPIC_SCAN_HISTORY 0

/* pose: payload fastslam::PoseEstimate, user header none */
#define FASTSLAM_TOPIC_POSE "pose"
#define FASTSLAM_TOPIC_POSE_BUFFER 256
#define FASTSLAM_TOPIC_POSE_HISTORY 0

/* map: payload [fastslam::MapLandmark], user header fastslam::LandmarkMapHeader */
#define FASTSLAM_TOPIC_MAP "map"
#define FASTSLAM_TOPIC_MAP_BUFFER 4
#define FASTSLAM_TOPIC_MAP_HISTORY 1

/* grid: payload [i8] (cells), user header fastslam::OccupancyGridHeader */
#define FASTSLAM_TOPIC_GRID "grid"
#define FASTSLAM_TOPIC_GRID_BUFFER 2
#define FASTSLAM_TOPIC_GRID_HISTORY 1

/* smoothed/trajectory: payload [fastslam::TrajectoryPose], user header fastslam::TrajectoryHeader */
#define FASTSLAM_TOPIC_SMOOTHED_TRAJECTORY "smoothed/trajectory"
#define FASTSLAM_TOPIC_SMOOTHED_TRAJECTORY_BUFFER 2
#define FASTSLAM_TOPIC_SMOOTHED_TRAJECTORY_HISTORY 1

/* smoothed/map: payload [fastslam::MapLandmark], user header fastslam::LandmarkMapHeader */
#define FASTSLAM_TOPIC_SMOOTHED_MAP "smoothed/map"
#define FASTSLAM_TOPIC_SMOOTHED_MAP_BUFFER 2
#define FASTSLAM_TOPIC_SMOOTHED_MAP_HISTORY 1

/* particles: payload [fastslam::Particle], user header fastslam::ParticlesHeader */
#define FASTSLAM_TOPIC_PARTICLES "particles"
#define FASTSLAM_TOPIC_PARTICLES_BUFFER 16
#define FASTSLAM_TOPIC_PARTICLES_HISTORY 0

/* status: payload fastslam::ServiceStatus, user header none */
#define FASTSLAM_TOPIC_STATUS "status"
#define FASTSLAM_TOPIC_STATUS_BUFFER 256
#define FASTSLAM_TOPIC_STATUS_HISTORY 1

/* checkpoint: payload fastslam::Checkpointed, user header none */
#define FASTSLAM_TOPIC_CHECKPOINT "checkpoint"
#define FASTSLAM_TOPIC_CHECKPOINT_BUFFER 16
#define FASTSLAM_TOPIC_CHECKPOINT_HISTORY 1

/* end_of_stream: payload fastslam::EndOfStream, user header none */
#define FASTSLAM_TOPIC_END_OF_STREAM "end_of_stream"
#define FASTSLAM_TOPIC_END_OF_STREAM_BUFFER 16
#define FASTSLAM_TOPIC_END_OF_STREAM_HISTORY 0

#define FASTSLAM_STREAM_GROUND_TRUTH 1
#define FASTSLAM_STREAM_ODOMETRY 2
#define FASTSLAM_STREAM_OBSERVATIONS 3
#define FASTSLAM_STREAM_POSE 4
#define FASTSLAM_STREAM_MAP 5
#define FASTSLAM_STREAM_STATUS 6
#define FASTSLAM_STREAM_SCAN 7
#define FASTSLAM_STREAM_GRID 8
#define FASTSLAM_STREAM_SMOOTHED_TRAJECTORY 9
#define FASTSLAM_STREAM_SMOOTHED_MAP 10
#define FASTSLAM_STREAM_PARTICLES 11

typedef struct fastslam_Header {
    uint64_t stamp_ns; /* ns */
    uint64_t seq; /* — */
} fastslam_Header;

/* fastslam::GroundTruth: true pose and the controls that led to it */
#define FASTSLAM_GROUND_TRUTH_TYPE_NAME "fastslam::GroundTruth"
typedef struct fastslam_GroundTruth {
    fastslam_Header header;
    double x; /* m: position x, frame `map` */
    double y; /* m: position y */
    double theta; /* rad: heading in (−π, π] */
    double v; /* m/s: true speed over the interval ending at the stamp */
    double omega; /* rad/s: true yaw rate over that interval */
    double steering; /* rad: true steering angle (0 for differential drive) */
} fastslam_GroundTruth;
_Static_assert(sizeof(fastslam_GroundTruth) == 64, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(_Alignof(fastslam_GroundTruth) == 8, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, header.stamp_ns) == 0, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, header.seq) == 8, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, x) == 16, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, y) == 24, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, theta) == 32, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, v) == 40, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, omega) == 48, "fastslam_GroundTruth must match the Rust layout");
_Static_assert(offsetof(fastslam_GroundTruth, steering) == 56, "fastslam_GroundTruth must match the Rust layout");

/* fastslam::Odometry: odometry pose in `odom`; measured speed, yaw rate, steering */
#define FASTSLAM_ODOMETRY_TYPE_NAME "fastslam::Odometry"
typedef struct fastslam_Odometry {
    fastslam_Header header;
    double v; /* m/s: measured forward speed (0 when unknown) */
    double omega; /* rad/s: measured yaw rate (differential drive; 0 when unknown) */
    double steering; /* rad: measured steering angle (car-like) */
    double x; /* m: odometry x, frame `odom` */
    double y; /* m: odometry y */
    double theta; /* rad: odometry heading */
} fastslam_Odometry;
_Static_assert(sizeof(fastslam_Odometry) == 64, "fastslam_Odometry must match the Rust layout");
_Static_assert(_Alignof(fastslam_Odometry) == 8, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, header.stamp_ns) == 0, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, header.seq) == 8, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, v) == 16, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, omega) == 24, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, steering) == 32, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, x) == 40, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, y) == 48, "fastslam_Odometry must match the Rust layout");
_Static_assert(offsetof(fastslam_Odometry, theta) == 56, "fastslam_Odometry must match the Rust layout");

/* fastslam::ObservationsHeader: header of one scan's landmark observations */
#define FASTSLAM_OBSERVATIONS_HEADER_TYPE_NAME "fastslam::ObservationsHeader"
typedef struct fastslam_ObservationsHeader {
    fastslam_Header header;
    uint32_t count; /* —: number of observations (= slice length) */
    uint32_t reserved; /* —: 0 */
    double max_range; /* m: the sensor's maximum range */
    double min_bearing; /* rad: smallest bearing the sensor covers */
    double max_bearing; /* rad: largest bearing the sensor covers */
} fastslam_ObservationsHeader;
_Static_assert(sizeof(fastslam_ObservationsHeader) == 48, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_ObservationsHeader) == 8, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, header.stamp_ns) == 0, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, header.seq) == 8, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, count) == 16, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, reserved) == 20, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, max_range) == 24, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, min_bearing) == 32, "fastslam_ObservationsHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ObservationsHeader, max_bearing) == 40, "fastslam_ObservationsHeader must match the Rust layout");

/* fastslam::Observation: one range–bearing observation */
#define FASTSLAM_OBSERVATION_TYPE_NAME "fastslam::Observation"
typedef struct fastslam_Observation {
    double range; /* m: range to the landmark's centre, in (0, max_range] */
    double bearing; /* rad: bearing, vehicle frame */
    double diameter; /* m: measured diameter, 0 when unknown */
    int64_t id; /* —: landmark id when known (known association: 0 to 2²⁰ − 1, else the message is rejected as `out_of_range`), −1 otherwise */
} fastslam_Observation;
_Static_assert(sizeof(fastslam_Observation) == 32, "fastslam_Observation must match the Rust layout");
_Static_assert(_Alignof(fastslam_Observation) == 8, "fastslam_Observation must match the Rust layout");
_Static_assert(offsetof(fastslam_Observation, range) == 0, "fastslam_Observation must match the Rust layout");
_Static_assert(offsetof(fastslam_Observation, bearing) == 8, "fastslam_Observation must match the Rust layout");
_Static_assert(offsetof(fastslam_Observation, diameter) == 16, "fastslam_Observation must match the Rust layout");
_Static_assert(offsetof(fastslam_Observation, id) == 24, "fastslam_Observation must match the Rust layout");

/* fastslam::PoseEstimate: estimated pose with 3×3 covariance */
#define FASTSLAM_POSE_ESTIMATE_TYPE_NAME "fastslam::PoseEstimate"
typedef struct fastslam_PoseEstimate {
    fastslam_Header header;
    double x; /* m: position x, frame `map` */
    double y; /* m: position y */
    double theta; /* rad: heading */
    double covariance[9]; /* m², m·rad, rad²: covariance of (x, y, θ), row-major */
} fastslam_PoseEstimate;
_Static_assert(sizeof(fastslam_PoseEstimate) == 112, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(_Alignof(fastslam_PoseEstimate) == 8, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, header.stamp_ns) == 0, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, header.seq) == 8, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, x) == 16, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, y) == 24, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, theta) == 32, "fastslam_PoseEstimate must match the Rust layout");
_Static_assert(offsetof(fastslam_PoseEstimate, covariance) == 40, "fastslam_PoseEstimate must match the Rust layout");

/* fastslam::LandmarkMapHeader: header of a landmark map */
#define FASTSLAM_LANDMARK_MAP_HEADER_TYPE_NAME "fastslam::LandmarkMapHeader"
typedef struct fastslam_LandmarkMapHeader {
    fastslam_Header header;
    uint32_t count; /* —: number of landmarks (= slice length) */
    uint32_t reserved; /* —: 0 */
} fastslam_LandmarkMapHeader;
_Static_assert(sizeof(fastslam_LandmarkMapHeader) == 24, "fastslam_LandmarkMapHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_LandmarkMapHeader) == 8, "fastslam_LandmarkMapHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LandmarkMapHeader, header.stamp_ns) == 0, "fastslam_LandmarkMapHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LandmarkMapHeader, header.seq) == 8, "fastslam_LandmarkMapHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LandmarkMapHeader, count) == 16, "fastslam_LandmarkMapHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LandmarkMapHeader, reserved) == 20, "fastslam_LandmarkMapHeader must match the Rust layout");

/* fastslam::MapLandmark: one landmark: mean and covariance */
#define FASTSLAM_MAP_LANDMARK_TYPE_NAME "fastslam::MapLandmark"
typedef struct fastslam_MapLandmark {
    uint64_t id; /* —: stable id within the map */
    double x; /* m: mean x, frame `map` */
    double y; /* m: mean y */
    double cov_xx; /* m²: covariance xx */
    double cov_xy; /* m²: covariance xy */
    double cov_yy; /* m²: covariance yy */
    uint64_t observations; /* —: times observed (0 in a true map) */
} fastslam_MapLandmark;
_Static_assert(sizeof(fastslam_MapLandmark) == 56, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(_Alignof(fastslam_MapLandmark) == 8, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, id) == 0, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, x) == 8, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, y) == 16, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, cov_xx) == 24, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, cov_xy) == 32, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, cov_yy) == 40, "fastslam_MapLandmark must match the Rust layout");
_Static_assert(offsetof(fastslam_MapLandmark, observations) == 48, "fastslam_MapLandmark must match the Rust layout");

/* fastslam::MapRequest: a request for the current map (`map/get`) */
#define FASTSLAM_MAP_REQUEST_TYPE_NAME "fastslam::MapRequest"
typedef struct fastslam_MapRequest {
    uint64_t reserved; /* —: 0 */
} fastslam_MapRequest;
_Static_assert(sizeof(fastslam_MapRequest) == 8, "fastslam_MapRequest must match the Rust layout");
_Static_assert(_Alignof(fastslam_MapRequest) == 8, "fastslam_MapRequest must match the Rust layout");
_Static_assert(offsetof(fastslam_MapRequest, reserved) == 0, "fastslam_MapRequest must match the Rust layout");

/* fastslam::StreamStatus: one input stream's state, an entry of the service's status */
#define FASTSLAM_STREAM_STATUS_TYPE_NAME "fastslam::StreamStatus"
typedef struct fastslam_StreamStatus {
    uint32_t stream; /* —: the stream id (`EndOfStream.stream`'s values); 0 in an unused entry */
    uint32_t queued; /* —: inputs of the stream waiting in the service's queue */
    uint64_t last_input_ns; /* ns: newest accepted stamp of the stream (0 before the first) */
    uint32_t quiet; /* —: 1: quiet beyond its deadline, not waited for (odometry: scans are processed without prediction; the lidar: odometry keeps predicting); 0: heard from in time */
    uint32_t reserved; /* —: 0 */
} fastslam_StreamStatus;
_Static_assert(sizeof(fastslam_StreamStatus) == 24, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(_Alignof(fastslam_StreamStatus) == 8, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamStatus, stream) == 0, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamStatus, queued) == 4, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamStatus, last_input_ns) == 8, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamStatus, quiet) == 16, "fastslam_StreamStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamStatus, reserved) == 20, "fastslam_StreamStatus must match the Rust layout");

/* fastslam::ServiceStatus: the service's filter health and input bookkeeping */
#define FASTSLAM_SERVICE_STATUS_TYPE_NAME "fastslam::ServiceStatus"
typedef struct fastslam_ServiceStatus {
    fastslam_Header header;
    uint64_t steps; /* —: observation steps done */
    uint64_t resamplings; /* —: times the particles were resampled */
    double n_eff; /* —: effective sample size of the last step, before resampling */
    uint32_t particles; /* —: number of particles */
    uint32_t distinct_particles; /* —: distinct particles after the last step */
    uint64_t landmarks; /* —: landmarks in the best particle's map */
    uint64_t step_time_ns; /* ns: wall-clock time of the last filter update, sending its pose included (the pose goes out before the maps are updated, so it is seen earlier than this) */
    uint32_t flags; /* —: bit 0: the last step resampled; bit 1: degraded (an input is quiet beyond its deadline: which one, `streams[k].quiet`); bit 4: final status, sent at shutdown (not a step); bit 5: noise check failed (NIS above its χ² band for a whole window); bit 6: with bit 5, the odometry noise is suspected, else the sensor's (the noise fit's verdict once warmed up, before it whether the pose term dominates the innovations); bit 7: the smoothing back-end's newest solve was torn and withheld (the smoothed topics hold an older solution, or none); bit 8: the landmark filter associates its observations without ids (unknown association), set on every status; bits 2 and 3 unused */
    uint32_t nis_dof; /* —: degrees of freedom in the noise check's window (2 per matched observation) */
    uint64_t rejections[16]; /* —: rejected inputs by reason: 0 non-finite, 1 out of range, 2 bad count, 3 stamp backwards, 4 refused by the filter, 5 duplicate seq, 6 stamp jump, 7 teleporting odometry, 8 queue overflow (oldest dropped), 9 late (after a quiet stream), 10 lost (sent while the service was down, no longer kept by its sensor for the resumed service), 11 covered (skipped by a resumed service: its checkpoint already holds it; the input that begins a resend is not counted) */
    double nis; /* —: noise check: NIS per degree of freedom over the last 50 scans, predicted from the motion prior (1 when the noise model fits; NaN before any match; docs/ALGORITHMS.md) */
    uint32_t stream_count; /* —: entries of `streams` in use */
    uint32_t torn_solves; /* —: solves of the smoothing back-end withheld as torn so far (docs/ALGORITHMS.md); 0 without a back-end */
    fastslam_StreamStatus streams[4]; /* —: the service's input streams (odometry first, then the lidar), the first `stream_count` entries */
    double noise_profile[4]; /* m/s or m/√m, rad/s or rad or rad/√rad, m, rad: the configured noise as standard deviations: the motion model's two (`sigma_v` and `sigma_omega` or `sigma_steering`; increment: `translation_per_m`, `rotation_per_rad`), `sigma_range`, `sigma_bearing` (0 without a noise fit) */
    double noise_fitted[4]; /* as `noise_profile: the same four as fitted (docs/ALGORITHMS.md §1, "Noise fit"): by the smoothing back-end's variance components once it has solved the whole graph (§8.4), else from the innovations (the profile's until that fit has warmed up); 0 without a noise fit */
    uint32_t noise_fit; /* —: where `noise_fitted` comes from: 0 no noise fit, 1 the filter's innovations, 2 the smoothing back-end's newest whole solve */
    uint32_t noise_suspect; /* —: the source the noise check blames: 0 none, 1 the odometry, 2 the sensor. With `noise_fit` 2, the back-end's verdict (a group's variance at least twice the model's, the larger); else that of the failed NIS check (bits 5 and 6 of `flags`) */
} fastslam_ServiceStatus;
_Static_assert(sizeof(fastslam_ServiceStatus) == 384, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(_Alignof(fastslam_ServiceStatus) == 8, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, header.stamp_ns) == 0, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, header.seq) == 8, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, steps) == 16, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, resamplings) == 24, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, n_eff) == 32, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, particles) == 40, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, distinct_particles) == 44, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, landmarks) == 48, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, step_time_ns) == 56, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, flags) == 64, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, nis_dof) == 68, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, rejections) == 72, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, nis) == 200, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, stream_count) == 208, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, torn_solves) == 212, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, streams) == 216, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, noise_profile) == 312, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, noise_fitted) == 344, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, noise_fit) == 376, "fastslam_ServiceStatus must match the Rust layout");
_Static_assert(offsetof(fastslam_ServiceStatus, noise_suspect) == 380, "fastslam_ServiceStatus must match the Rust layout");

/* fastslam::StreamCovered: what a checkpoint holds of one input stream */
#define FASTSLAM_STREAM_COVERED_TYPE_NAME "fastslam::StreamCovered"
typedef struct fastslam_StreamCovered {
    uint32_t stream; /* —: the stream id (`EndOfStream.stream`'s values); 0 in an unused entry */
    uint32_t reserved; /* —: 0 */
    uint64_t covered_ns; /* ns: stamp of the stream's last input the checkpoint holds */
} fastslam_StreamCovered;
_Static_assert(sizeof(fastslam_StreamCovered) == 16, "fastslam_StreamCovered must match the Rust layout");
_Static_assert(_Alignof(fastslam_StreamCovered) == 8, "fastslam_StreamCovered must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamCovered, stream) == 0, "fastslam_StreamCovered must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamCovered, reserved) == 4, "fastslam_StreamCovered must match the Rust layout");
_Static_assert(offsetof(fastslam_StreamCovered, covered_ns) == 8, "fastslam_StreamCovered must match the Rust layout");

/* fastslam::Checkpointed: what the service's last checkpoint covers; a resumed service's request */
#define FASTSLAM_CHECKPOINTED_TYPE_NAME "fastslam::Checkpointed"
typedef struct fastslam_Checkpointed {
    fastslam_Header header;
    uint32_t stream_count; /* —: entries of `covered` in use */
    uint32_t resume; /* —: 1: a resumed service asks for everything after `covered_ns`; 0: a checkpoint was written */
    fastslam_StreamCovered covered[4]; /* —: per input stream, the stamp of the last input the checkpoint holds: the first `stream_count` entries */
} fastslam_Checkpointed;
_Static_assert(sizeof(fastslam_Checkpointed) == 88, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(_Alignof(fastslam_Checkpointed) == 8, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(offsetof(fastslam_Checkpointed, header.stamp_ns) == 0, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(offsetof(fastslam_Checkpointed, header.seq) == 8, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(offsetof(fastslam_Checkpointed, stream_count) == 16, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(offsetof(fastslam_Checkpointed, resume) == 20, "fastslam_Checkpointed must match the Rust layout");
_Static_assert(offsetof(fastslam_Checkpointed, covered) == 24, "fastslam_Checkpointed must match the Rust layout");

/* fastslam::ClientNotice: what the client has recorded; a restarted client's request */
#define FASTSLAM_CLIENT_NOTICE_TYPE_NAME "fastslam::ClientNotice"
typedef struct fastslam_ClientNotice {
    fastslam_Header header;
    uint64_t restarts; /* —: how many times the client recording this run was started again after it died */
    uint64_t recorded[12]; /* —: per stream (index: `EndOfStream.stream`'s value), the sequence number below which every message is recorded; for maps, grids and smoothed trajectories, one past the newest recorded */
    uint64_t ended; /* —: bit `s` set: the end of stream `s` is recorded */
    uint64_t finished; /* —: 1 once the client has written its run folder */
} fastslam_ClientNotice;
_Static_assert(sizeof(fastslam_ClientNotice) == 136, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(_Alignof(fastslam_ClientNotice) == 8, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, header.stamp_ns) == 0, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, header.seq) == 8, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, restarts) == 16, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, recorded) == 24, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, ended) == 120, "fastslam_ClientNotice must match the Rust layout");
_Static_assert(offsetof(fastslam_ClientNotice, finished) == 128, "fastslam_ClientNotice must match the Rust layout");

/* fastslam::EndOfStream: "this stream is finished" */
#define FASTSLAM_END_OF_STREAM_TYPE_NAME "fastslam::EndOfStream"
typedef struct fastslam_EndOfStream {
    fastslam_Header header;
    uint32_t stream; /* —: 1 ground truth, 2 odometry, 3 observations, 4 pose, 5 map, 6 status, 7 scan, 8 grid, 9 smoothed trajectory, 10 smoothed map, 11 particles */
    uint32_t reserved; /* —: 0 */
} fastslam_EndOfStream;
_Static_assert(sizeof(fastslam_EndOfStream) == 24, "fastslam_EndOfStream must match the Rust layout");
_Static_assert(_Alignof(fastslam_EndOfStream) == 8, "fastslam_EndOfStream must match the Rust layout");
_Static_assert(offsetof(fastslam_EndOfStream, header.stamp_ns) == 0, "fastslam_EndOfStream must match the Rust layout");
_Static_assert(offsetof(fastslam_EndOfStream, header.seq) == 8, "fastslam_EndOfStream must match the Rust layout");
_Static_assert(offsetof(fastslam_EndOfStream, stream) == 16, "fastslam_EndOfStream must match the Rust layout");
_Static_assert(offsetof(fastslam_EndOfStream, reserved) == 20, "fastslam_EndOfStream must match the Rust layout");

/* fastslam::LaserScanHeader: header of one raw lidar scan */
#define FASTSLAM_LASER_SCAN_HEADER_TYPE_NAME "fastslam::LaserScanHeader"
typedef struct fastslam_LaserScanHeader {
    fastslam_Header header;
    float angle_min; /* rad: direction of the first beam (0 = forward, counter-clockwise) */
    float angle_increment; /* rad: angle between beams, > 0 (beams sweep counter-clockwise) */
    float time_increment; /* s: time between beams, ≥ 0 (0: instantaneous scan) */
    float scan_time; /* s: time between scans, ≥ 0 */
    float range_min; /* m: shortest measurable range */
    float range_max; /* m: longest measurable range */
    uint32_t ranges; /* —: number of ranges, 1..=65536 */
    uint32_t intensities; /* —: number of intensities after the ranges: 0 or `ranges` */
} fastslam_LaserScanHeader;
_Static_assert(sizeof(fastslam_LaserScanHeader) == 48, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_LaserScanHeader) == 8, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, header.stamp_ns) == 0, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, header.seq) == 8, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, angle_min) == 16, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, angle_increment) == 20, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, time_increment) == 24, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, scan_time) == 28, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, range_min) == 32, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, range_max) == 36, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, ranges) == 40, "fastslam_LaserScanHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_LaserScanHeader, intensities) == 44, "fastslam_LaserScanHeader must match the Rust layout");

/* fastslam::OccupancyGridHeader: header of an occupancy grid map */
#define FASTSLAM_OCCUPANCY_GRID_HEADER_TYPE_NAME "fastslam::OccupancyGridHeader"
typedef struct fastslam_OccupancyGridHeader {
    fastslam_Header header;
    double resolution; /* m: side of a square cell */
    double origin_x; /* m: x of cell (0, 0)'s lower-left corner, frame `map` */
    double origin_y; /* m: y of that corner */
    double origin_theta; /* rad: rotation of the grid about its origin */
    uint32_t width; /* —: cells per row (along x) */
    uint32_t height; /* —: rows (along y) */
} fastslam_OccupancyGridHeader;
_Static_assert(sizeof(fastslam_OccupancyGridHeader) == 56, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_OccupancyGridHeader) == 8, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, header.stamp_ns) == 0, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, header.seq) == 8, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, resolution) == 16, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, origin_x) == 24, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, origin_y) == 32, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, origin_theta) == 40, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, width) == 48, "fastslam_OccupancyGridHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_OccupancyGridHeader, height) == 52, "fastslam_OccupancyGridHeader must match the Rust layout");

/* fastslam::TrajectoryHeader: header of a smoothed trajectory */
#define FASTSLAM_TRAJECTORY_HEADER_TYPE_NAME "fastslam::TrajectoryHeader"
typedef struct fastslam_TrajectoryHeader {
    fastslam_Header header;
    uint32_t count; /* —: number of poses (= slice length) */
    uint32_t solves; /* —: solves run so far, this one included */
    double chi2_per_dof; /* —: χ² per degree of freedom at the solution (≈ 1 when the noise model and associations hold) */
} fastslam_TrajectoryHeader;
_Static_assert(sizeof(fastslam_TrajectoryHeader) == 32, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_TrajectoryHeader) == 8, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryHeader, header.stamp_ns) == 0, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryHeader, header.seq) == 8, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryHeader, count) == 16, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryHeader, solves) == 20, "fastslam_TrajectoryHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryHeader, chi2_per_dof) == 24, "fastslam_TrajectoryHeader must match the Rust layout");

/* fastslam::TrajectoryPose: one pose of a trajectory */
#define FASTSLAM_TRAJECTORY_POSE_TYPE_NAME "fastslam::TrajectoryPose"
typedef struct fastslam_TrajectoryPose {
    uint64_t stamp_ns; /* ns: stamp of the pose */
    double x; /* m: position x, frame `map` */
    double y; /* m: position y */
    double theta; /* rad: heading */
} fastslam_TrajectoryPose;
_Static_assert(sizeof(fastslam_TrajectoryPose) == 32, "fastslam_TrajectoryPose must match the Rust layout");
_Static_assert(_Alignof(fastslam_TrajectoryPose) == 8, "fastslam_TrajectoryPose must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryPose, stamp_ns) == 0, "fastslam_TrajectoryPose must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryPose, x) == 8, "fastslam_TrajectoryPose must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryPose, y) == 16, "fastslam_TrajectoryPose must match the Rust layout");
_Static_assert(offsetof(fastslam_TrajectoryPose, theta) == 24, "fastslam_TrajectoryPose must match the Rust layout");

/* fastslam::ParticlesHeader: header of a particle cloud */
#define FASTSLAM_PARTICLES_HEADER_TYPE_NAME "fastslam::ParticlesHeader"
typedef struct fastslam_ParticlesHeader {
    fastslam_Header header;
    uint32_t count; /* —: number of particles (= slice length) */
    uint32_t reserved; /* —: 0 */
} fastslam_ParticlesHeader;
_Static_assert(sizeof(fastslam_ParticlesHeader) == 24, "fastslam_ParticlesHeader must match the Rust layout");
_Static_assert(_Alignof(fastslam_ParticlesHeader) == 8, "fastslam_ParticlesHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ParticlesHeader, header.stamp_ns) == 0, "fastslam_ParticlesHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ParticlesHeader, header.seq) == 8, "fastslam_ParticlesHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ParticlesHeader, count) == 16, "fastslam_ParticlesHeader must match the Rust layout");
_Static_assert(offsetof(fastslam_ParticlesHeader, reserved) == 20, "fastslam_ParticlesHeader must match the Rust layout");

/* fastslam::Particle: one particle: pose and weight */
#define FASTSLAM_PARTICLE_TYPE_NAME "fastslam::Particle"
typedef struct fastslam_Particle {
    double x; /* m: position x, frame `map` */
    double y; /* m: position y */
    double theta; /* rad: heading */
    double weight; /* —: normalised weight, ≥ 0 (the cloud's weights sum to 1) */
} fastslam_Particle;
_Static_assert(sizeof(fastslam_Particle) == 32, "fastslam_Particle must match the Rust layout");
_Static_assert(_Alignof(fastslam_Particle) == 8, "fastslam_Particle must match the Rust layout");
_Static_assert(offsetof(fastslam_Particle, x) == 0, "fastslam_Particle must match the Rust layout");
_Static_assert(offsetof(fastslam_Particle, y) == 8, "fastslam_Particle must match the Rust layout");
_Static_assert(offsetof(fastslam_Particle, theta) == 16, "fastslam_Particle must match the Rust layout");
_Static_assert(offsetof(fastslam_Particle, weight) == 24, "fastslam_Particle must match the Rust layout");

#endif /* FASTSLAM_PROTOCOL_H */
