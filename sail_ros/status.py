"""The keys of the status values on /diagnostics, in one place.

The simulator's integrator status: the simulator writes them
(`runtime.realtime.RealTimeRun.status`); `watch`, `report`, the log reader, the client
and the main job read them. msg_docs/diagnostics.md describes each. The bridge's
status (`nodes.bridge`) follows, msg_docs/bridge.md describes it.
"""

STATE = "state"  # running, paused or error
SIM_TIME = "sim_time_s"  # simulation time now [s]
# state samples published since start: each state topic's writer numbers its samples
# 1, 2, ... (DDS's publication sequence number), so a reader knows it holds the newest
STATE_SAMPLES = "state_samples"
REAL_TIME_FACTOR = "real_time_factor"  # simulated s per wall s, last complete window
REAL_TIME_FACTOR_WINDOW = "real_time_factor_window_s"  # that window [s of wall time]
TIME_SCALE = "time_scale"  # the one asked for
STEP_TIME_MEAN = "step_time_ms_mean"  # wall time per grid step over the window [ms]
STEP_TIME_MAX = "step_time_ms_max"
STEPS_IN_WINDOW = "steps_in_window"
OVERRUNS = "overruns"  # ticks that found the model more than a step behind, since start
REALTIME_PRIORITY = "realtime_priority"  # SCHED_FIFO priority in force; 0: normal
ACCEPTED = "accepted_commands"  # since start, per outcome
SUPERSEDED = "superseded_commands"
REJECTED = "rejected_commands"
IGNORED = "ignored_commands"
MISSED_COMMANDS = "missed_commands"  # steps that waited command_wait_s for a hub wrench in vain
DROPPED = "dropped_commands"  # of the rejected: refused because the intake was full
LAST_COMMAND = "last_command"
LAST_COMMAND_START = "last_command_start_s"
LAST_REJECTION = "last_rejection"
MOTION_END = "motion_end_s"
MODEL_RTOL = "model_rtol"  # the tolerance of the moving steps (relative to peak)
# the accumulated error estimate relative to peak, the largest of tips and root moments
ERROR_ESTIMATE = "relative_error_estimate"
ENERGY = "mechanical_energy_J"
LOAD_POWER = "load_power_W"
DISSIPATION = "damping_dissipation_W"

# -- the bridge's status (msg_docs/bridge.md) --------------------------------------------------
BRIDGE_URL = "url"  # where the bridge serves
CLIENTS = "clients"  # clients subscribed to at least one channel
CONNECTIONS = "connections"  # clients connected (their WebSocket handshake done)
REFUSED_CONNECTIONS = "refused_connections"  # clients disconnected beyond max_clients
SERVER_PROBLEMS = "server_problems"  # warnings and errors the server logged, since start
CHANNELS = "channels"  # topics served
SERVED = "messages_served"  # messages handed to the server, since start
CLIENT_COMMANDS = "client_commands"  # client messages published on DDS, since start
REFUSED = "refused_client_messages"  # client messages or channels refused, since start
LAST_REFUSAL = "last_refusal"
SERVICE_CALLS = "service_calls"  # protocol service calls answered, since start
SLOW_REPORTS = "slow_client_reports"  # the server's reports of a client's full queue
SLOW_CLIENTS = "slow_clients"  # the addresses it reported
