//! The defect classes every case belongs to, and their order in the
//! summary.

/// Classes (issue 9's numbered defects and the paper audit).
pub const DURATION: &str = "1 float to duration";
pub const PIPE: &str = "2 broken pipe";
pub const MEMORY: &str = "3 unbounded memory";
pub const WORK: &str = "4 unbounded work";
pub const CENTROIDS: &str = "5 wild centroids";
pub const PLANS: &str = "6 silently wrong plans";
pub const EXIT: &str = "7 exit codes";
pub const SESSIONS: &str = "8 streaming sessions";
pub const PLAY: &str = "9 play semantics";
pub const SPEC: &str = "10 spec and implementation agree";
pub const VALIDATION: &str = "11 one header, one validation";
pub const UNTRACKED: &str = "untracked play and mute reason";
pub const PAPER: &str = "paper fidelity";
/// Classes of issue 18 (hostile input, round 3).
pub const OUTPUT_ERRORS: &str = "r3-1 output errors";
pub const SAME_FILE: &str = "r3-3 an output that is an input";
pub const PARTIAL: &str = "r3-4 no partial outputs";
pub const ODD_PATHS: &str = "r3-5 odd input paths";
pub const PATH_MESSAGES: &str = "r3-11 input-path messages";
pub const NUMBERS: &str = "r3-7 numbers in messages";
pub const PORTS: &str = "r3-10 port strings";
pub const REC_SIGNAL: &str = "r3-2 recordings survive signals";
pub const STALLS: &str = "r3-6 stalls";
pub const RIG: &str = "r3-8 rig sanity";
pub const REFUSALS: &str = "r3-9 device refusals said";
/// One behaviour on every backend: stimulus flags and files.
pub const STIMULI: &str = "r4 stimulus flags and files";
/// The study's data (issues 31.5, 31.6, 30).
pub const STUDY_RESUME: &str = "r4-study-1 resume validates first";
pub const STUDY_LABELS: &str = "r4-study-2 labels and answers";
pub const STUDY_REPORT: &str = "r4-study-3 study report";
pub const STUDY_READS: &str = "r4-study-4 bounded regular study reads";
pub const STUDY_COUNTS: &str = "r4-study-5 counts that wrap";
pub const STUDY_NUMBERS: &str = "r4-study-6 numbers name the field";
/// Round 4, files (issues 30.4, 30.12, 30.16).
pub const OUT_DEST: &str = "r4-30.4 output destinations";
pub const EVENT_LOGS: &str = "r4-30.4 event logs never block";
pub const MESSAGES: &str = "r4-30.16 one reason, named fields, sane ranges";
pub const SCENE_EDITS: &str = "r4-30.16 scenes calibrated in any form";

/// The rig session (issues 30, 31.3): `cases_r4_session.rs`.
pub const SESSION_STALLS: &str = "r4-s1 no client slows the session";
pub const SESSION_LINES: &str = "r4-s2 bounded control lines";
pub const SESSION_TCP: &str = "r4-s3 local TCP control authenticated";
pub const SESSION_LIBRARY: &str = "r4-s4 library larger than the device";
pub const SESSION_MEANINGLESS: &str = "r4-s5 meaningless session input refused";
pub const SESSION_SEMANTICS: &str = "r4-s6 session semantics";
pub const SESSION_MESSAGES: &str = "r4-s7 session messages";
pub const SESSION_OUTPUTS: &str = "r4-s8 session inputs before outputs";

/// Classes of round 4's device work (issues 26, 30, 31).
pub const STALE_LOCK: &str = "r4-30.15 a port lock dies with its holder";
pub const AUTD3_SLOTS: &str = "r4-31 AUTD3 slots, segments and the in-process emulator";

/// Round 4, the paper's experiments (issue 28): `cases_r4_paper.rs`.
pub const PAPER_ANSWERS: &str = "r4-28.1 not perceived and answers as asked";
pub const PAPER_REPORT: &str = "r4-28.3 the report's tests declared";
pub const PAPER_RIG: &str = "r4-28.5 resume on the same rig";

/// Round 5, Experiment 3's instruments and the study's finger sources
/// (issue 28.2, 28.6): `cases_r5_exp3.rs`.
pub const EXP3_INSTRUMENTS: &str = "r5-28.2 stage and gauge flags";
pub const EXP3_SOURCES: &str = "r5-28.6 study finger sources";

/// The live view (issue 27): `cases_r4_view.rs`.
pub const VIEW_HTTP: &str = "r4-v1 bounded view requests";
pub const VIEW_ADDRESS: &str = "r4-v2 --view addresses";

/// Round 6, the sweep of every value flag (`cases_r6_sweep.rs`).
pub const SWEEP_IGNORED: &str = "r6-1 no flag silently ignored";
pub const SWEEP_EVERY_PATH: &str = "r6-2 one check on every path";
pub const SWEEP_NEGATIVE: &str = "r6-3 a negative number is a value";
pub const SWEEP_LONG: &str = "r6-4 a long value cut in its message";
pub const SWEEP_OUTPUT_FIRST: &str = "r6-5 an output is refused before the work";

/// Round 7a, the sweep of every field of every input file
/// (`cases_r7_files.rs`).
pub const FILES_EXACT: &str = "r7-f1 a file's vector is exactly its length";
pub const FILES_ONE_RULE: &str = "r7-f2 a file's value meets its flag's and device's rule";
pub const FILES_PLACE: &str = "r7-f3 a file's error names its line, key and trouble";
pub const FILES_IGNORED: &str = "r7-f4 no key of a file silently ignored";
pub const FILES_RESUME: &str = "r7-f5 --resume keeps only rows a run can write";

/// Round 7b, the sweep of what lmhost takes at run time (`cases_r7_wire.rs`).
pub const WIRE_DUPLICATE_KEYS: &str = "r7-w1 a key given twice is refused";
pub const WIRE_ECHO: &str = "r7-w2 a wrong-typed value cut at 64 characters";
pub const WIRE_ROUNDED: &str = "r7-w3 an on_s the device would round up is refused";
pub const WIRE_UTF8: &str = "r7-w4 a line not UTF-8 is refused as such";
pub const WIRE_NAMED: &str = "r7-w5 a refusal names its command";
pub const WIRE_BESIDE_BOUND: &str = "r7-w6 a value beside its bound is not shown as it";
pub const WIRE_TCP_REPLY: &str = "r7-w7 every closed TCP client gets its reply";
pub const WIRE_VIEW: &str = "r7-w8 a view request has one deadline and numbers";

/// Round 8, what rounds 6 and 7 noticed, fixed as classes, and a sweep of
/// run-time streams, control lines and depth frames (`cases_r8.rs`).
pub const NOTICED_CANNOT_APPLY: &str = "r8-1 a spacing for one focus is refused on every path";
pub const STREAM_TIME: &str = "r8-2 a centroid time stamp lies in 0 to 1e10 s";
pub const NOTICED_RESUME: &str =
    "r8-4 --resume refuses a row without its time or beyond a fraction";
pub const NOTICED_FILE_NAMED: &str = "r8-5 an error about a file's content names the file";
pub const NOTICED_TIDY: &str = "r8-6 a quoted number in a message is short";
pub const NOTICED_CHANGES_NOTHING: &str = "r8-7 a value that changes nothing is refused";
pub const STREAM_TROUBLE: &str = "r8-8 a stream line is refused for what it is";
pub const STREAM_NPY_TAIL: &str = "r8-9 an .npy header value with a tail is refused";
pub const DEVICE_INFO: &str = "r9-1 a device's impossible Info is refused at connect";
pub const R16W_STATUS_ZERO: &str =
    "r16w-1 a Status with a field the firmware holds at 0 there is refused";
pub const R16W_INFO_RIG: &str = "r16w-2 an Info with a rig CRC and no rig is refused";
pub const DEVICE_STATUS: &str = "r9-2 a device's impossible Status is refused";
pub const DEVICE_NAMED: &str = "r9-3 a link error names the port and the reply";
pub const DEVICE_HEARD: &str = "r9-4 an unanswered request says what came instead";
pub const DEVICE_LOSSY: &str =
    "r9-5 a link that loses replies: resent centroids, Ctrl-C mid-upload";
pub const DEVICE_UNBOUND: &str =
    "r9-6 a reply that echoes another request (replayed, made up) is refused";
/// Round 10: text as other tools and platforms write it.
pub const TEXT_BOM: &str = "r10-1 a leading byte-order mark is skipped, a later one named";
pub const TEXT_LINE_ENDS: &str = "r10-2 CRLF and a lone CR end a line";
pub const TEXT_WIDE: &str = "r10-3 UTF-16 and UTF-32 are named, with what to do";
pub const TEXT_NUL: &str = "r10-4 a NUL byte is named with its line";
pub const TEXT_CSV: &str = "r10-5 a CSV not ours is named, never misread";
/// Round 11: a fresh look by class (`cases_r11.rs`).
pub const R11_WHOLE: &str = "r11-1 a whole-number flag names its own range";
pub const R11_LISTS: &str = "r11-2 a message lists a few of many";
pub const R11_DIGITS: &str = "r11-3 a report line's number has at most 10 digits";
pub const R11_TIMING: &str = "r11-4 a study's timeline is checked as played before it starts";
pub const R11_SETUP: &str = "r11-5 a session failed in its set-up leaves its event log";
pub const R11_DIRS: &str = "r11-6 an output folder made and left empty is removed";
pub const R11_ENV: &str = "r11-7 a default from the environment is named as it";
pub const R11_OUTPUTS: &str = "r11-8 an output is a file where a file is meant";
pub const R11_LIST_NUMBERS: &str = "r11-9 a number inside a flag's list is read exactly";
/// Round 12: Python, streams and device replies (`cases_r12.rs`).
pub const R12_CONTROL_WHOLE: &str = "r12-1 a control line's whole number names its rule's range";
pub const R12_PORT_LONG: &str = "r12-2 a port name longer than any is refused, not echoed whole";
/// Round 13: what earlier rounds knew of and left (`cases_r13.rs`).
pub const R13_FILE_WHOLE: &str = "r13-1 a file's whole number names its field's range";
pub const R13_MISSING: &str = "r13-2 a missing field is named with where it was wanted";
pub const R13_EMPTY: &str = "r13-3 a recording of nothing is refused, naming it";
pub const R13_DERIVED: &str = "r13-4 a number is refused by its own range, not a derived overflow";
pub const R13_CHECK_RUN: &str = "r13-5 study check refuses the timeline study run refuses";
pub const R13_NOT_A_NUMBER: &str = "r13-6 a flag's value that is no number says what to give";
pub const R13_TOO_LARGE: &str = "r13-7 a number literal beyond a float is refused as itself";
pub const R13_SILENCE: &str = "r13-8 an intensity that rounds to silence is refused";
pub const R13_FILE_TEXT: &str = "r13-9 a file's text is bounded and free of control characters";
pub const R13_EMPTY_PORT: &str = "r13-10 an empty --port is refused, not taken for none";
pub const R13_NEGATIVE_WORDS: &str = "r13-12 a flag's value -inf or -nan is read as its value";
/// Round 13's follow-ups (`cases_r13b.rs`).
pub const R13_JSON_WHOLE: &str = "r13-14 a JSON file's whole number names its field and range";
pub const R13_PRESENT: &str = "r13-15 a centroid's present takes one set of values in JSON and CSV";
/// Round 14b: the device side, the live inputs and Python (`cases_r14b.rs`).
pub const R14B_HALF_CLOSED: &str = "r14b-2 a client that half-closes gets every reply";
pub const R14B_BEYOND_FLOAT: &str =
    "r14b-3 a number beyond a float on a live line is refused as itself, named";

/// Round 14 (`cases_r14.rs`).
pub const R14_OUTPUTS: &str = "r14-1 the outputs of one run never share a path";
pub const R14_PORT_FORM: &str = "r14-2 a port name of no port's form is refused, not opened";
pub const R14_JSON_TAIL: &str = "r14-3 a JSON file holds one value, nothing after it";
pub const R14_RANGES: &str = "r14-4 a refusal states the range its check allows";
pub const R14_EMPTY_PATH: &str =
    "r14-5 a path a file gives is refused when empty, naming its field";
pub const R14_NOT_A_FOLDER: &str = "r14-6 an output folder's path that is something else says what";
pub const R14_NO_TIME: &str = "r14-7 a duration that rounds to no time is refused";
/// Round 15b: where a model, a spec and the code disagree (`cases_r15b.rs`).
pub const R15B_MODEL_RANGE: &str =
    "r15b-1 every value a simulated instrument's flag allows is modelled";
pub const R15B_CAMERA: &str = "r15b-2 camera intrinsics no depth camera has are refused";
pub const R15B_PARTS: &str = "r15b-4 a flag of several parts names the part that is wrong";
pub const R15B_BAD_VALUE: &str =
    "r15b-5 a centroid object's bad value is refused as a value of its key";
pub const R15B_HANDED: &str = "r15b-6 a scene's left-handed lm_plane is refused";

/// Round 15a: values that change nothing, and refusals that disagree
/// (`cases_r15a.rs`).
pub const R15A_AWAY: &str = "r15a-1 an away window that holds no frame is refused";
pub const R15A_STEPS: &str = "r15a-2 a staircase's steps it can never use are refused";
pub const R15A_RATE: &str = "r15a-3 a gauge rate below one reading in the read is refused";
pub const R15A_REPLAN: &str = "r15a-4 --replan-mm has an upper bound";
pub const R15A_REPEATED: &str = "r15a-5 a repeatable flag's value given twice is refused";
pub const R15A_SPACES: &str = "r15a-6 a list's number with spaces is refused as a lone one";
pub const R15A_OFF: &str = "r15a-7 off_s's refusal states its range, 0 in it";
pub const R15A_ENV: &str = "r15a-8 a flag's variable not UTF-8 is named";

/// Round 16a: a sweep of the command line and its files (`cases_r16a.rs`).
pub const R16A_ADVICE: &str = "r16a-1 a refusal's advice is one its flag can take";
pub const R16A_NO_NUMBER: &str =
    "r16a-2 a value that is no number is refused in one wording, saying what it looks like";
pub const R16A_LESS: &str = "r16a-3 flags that together ask less than each says are refused";
pub const R16A_ENV: &str = "r16a-4 an LMHOST_* variable is taken as set or refused, naming it";
pub const R16A_NOT_OBJECT: &str = "r16a-6 a JSON file that is no object is named as what it is";
pub const R16A_WHICH_PART: &str =
    "r16a-7 an output its folder stops names the part of the path that is wrong";
pub const R16A_TOML_ARRAY: &str =
    "r16a-8 a TOML table written as an array is refused, not read by position";
pub const R16A_SIGNALS: &str =
    "r16a-5 every signal that would end the process leaves outputs whole or absent";

/// Every class the suite must cover.
pub const CLASSES: [&str; 145] = [
    DURATION,
    PIPE,
    MEMORY,
    WORK,
    CENTROIDS,
    PLANS,
    EXIT,
    SESSIONS,
    PLAY,
    SPEC,
    VALIDATION,
    UNTRACKED,
    PAPER,
    OUTPUT_ERRORS,
    SAME_FILE,
    PARTIAL,
    ODD_PATHS,
    PATH_MESSAGES,
    NUMBERS,
    PORTS,
    REC_SIGNAL,
    STALLS,
    RIG,
    REFUSALS,
    STIMULI,
    STUDY_RESUME,
    STUDY_LABELS,
    STUDY_REPORT,
    STUDY_READS,
    STUDY_COUNTS,
    STUDY_NUMBERS,
    OUT_DEST,
    EVENT_LOGS,
    MESSAGES,
    SCENE_EDITS,
    SESSION_STALLS,
    SESSION_LINES,
    SESSION_TCP,
    SESSION_LIBRARY,
    SESSION_MEANINGLESS,
    SESSION_SEMANTICS,
    SESSION_MESSAGES,
    SESSION_OUTPUTS,
    STALE_LOCK,
    AUTD3_SLOTS,
    PAPER_ANSWERS,
    PAPER_REPORT,
    PAPER_RIG,
    VIEW_HTTP,
    VIEW_ADDRESS,
    EXP3_INSTRUMENTS,
    EXP3_SOURCES,
    SWEEP_IGNORED,
    SWEEP_EVERY_PATH,
    SWEEP_NEGATIVE,
    SWEEP_LONG,
    SWEEP_OUTPUT_FIRST,
    FILES_EXACT,
    FILES_ONE_RULE,
    FILES_PLACE,
    FILES_IGNORED,
    FILES_RESUME,
    WIRE_DUPLICATE_KEYS,
    WIRE_ECHO,
    WIRE_ROUNDED,
    WIRE_UTF8,
    WIRE_NAMED,
    WIRE_BESIDE_BOUND,
    WIRE_TCP_REPLY,
    WIRE_VIEW,
    NOTICED_CANNOT_APPLY,
    STREAM_TIME,
    NOTICED_RESUME,
    NOTICED_FILE_NAMED,
    NOTICED_TIDY,
    NOTICED_CHANGES_NOTHING,
    STREAM_TROUBLE,
    STREAM_NPY_TAIL,
    DEVICE_INFO,
    DEVICE_STATUS,
    DEVICE_NAMED,
    DEVICE_HEARD,
    DEVICE_LOSSY,
    DEVICE_UNBOUND,
    R16W_STATUS_ZERO,
    R16W_INFO_RIG,
    TEXT_BOM,
    TEXT_LINE_ENDS,
    TEXT_WIDE,
    TEXT_NUL,
    TEXT_CSV,
    R11_WHOLE,
    R11_LISTS,
    R11_DIGITS,
    R11_TIMING,
    R11_SETUP,
    R11_DIRS,
    R11_ENV,
    R11_OUTPUTS,
    R11_LIST_NUMBERS,
    R12_CONTROL_WHOLE,
    R12_PORT_LONG,
    R13_FILE_WHOLE,
    R13_MISSING,
    R13_EMPTY,
    R13_DERIVED,
    R13_CHECK_RUN,
    R13_NOT_A_NUMBER,
    R13_TOO_LARGE,
    R13_SILENCE,
    R13_FILE_TEXT,
    R13_EMPTY_PORT,
    R13_NEGATIVE_WORDS,
    R13_JSON_WHOLE,
    R13_PRESENT,
    R14B_HALF_CLOSED,
    R14B_BEYOND_FLOAT,
    R14_OUTPUTS,
    R14_PORT_FORM,
    R14_JSON_TAIL,
    R14_RANGES,
    R14_EMPTY_PATH,
    R14_NOT_A_FOLDER,
    R14_NO_TIME,
    R15B_MODEL_RANGE,
    R15B_CAMERA,
    R15B_PARTS,
    R15B_BAD_VALUE,
    R15B_HANDED,
    R15A_AWAY,
    R15A_STEPS,
    R15A_RATE,
    R15A_REPLAN,
    R15A_REPEATED,
    R15A_SPACES,
    R15A_OFF,
    R15A_ENV,
    R16A_ADVICE,
    R16A_NO_NUMBER,
    R16A_LESS,
    R16A_ENV,
    R16A_SIGNALS,
    R16A_NOT_OBJECT,
    R16A_WHICH_PART,
    R16A_TOML_ARRAY,
];
