//! What the controllers' numbered answers mean: `error:N` and `ALARM:N` of Grbl 1.1, and the
//! codes grblHAL (its `errors.h`, `alarms.h`) and FluidNC (its `Error.h`, `Alarm.h`) add. The
//! three agree on Grbl's own codes; above them a number means something different on each,
//! so the text names the firmware that means it (a board says which it is on connect, but an
//! error is worded where only its number is known).

/// What an `error:N` means (Grbl 1.1, codes 1..38, which grblHAL and FluidNC share; beyond
/// them, what each of those two means by it), in our words.
pub(crate) fn error_meaning(code: u8) -> &'static str {
    match code {
        1 => "a word without its letter: G-code words are a letter followed by a number",
        2 => "a number is missing or malformed",
        3 => "not a Grbl '$' command",
        4 => "a value that must be positive is negative",
        5 => "homing is not enabled in the settings ($22)",
        6 => "the step pulse time must be at least 3 microseconds",
        7 => "the settings memory (EEPROM) could not be read; defaults were restored",
        8 => "this '$' command only runs while the machine is idle",
        9 => "G-code is locked out during an alarm or a jog; unlock ($X) or home ($H) first",
        10 => "soft limits need homing enabled",
        11 => {
            "the line is longer than Grbl's line buffer (79 characters without spaces and comments)"
        }
        12 => "the setting would make the step rate exceed what the board can drive",
        13 => "the safety door is open",
        14 => "the build info or startup line is too long for the settings memory",
        15 => "the jog target is outside the machine's travel",
        16 => "a jog command without '=' or with a G-code jogging does not allow",
        17 => "laser mode needs the spindle PWM output",
        20 => "an unsupported or invalid G-code command",
        21 => "two commands from the same modal group on one line",
        22 => "a feed move (G1/G2/G3) before any feed rate F was set",
        23 => "this command needs an integer value",
        24 => "two commands on one line both want the axis words",
        25 => "the same word appears twice on one line",
        26 => "a command that needs axis words has none",
        27 => "the line number N is out of range",
        28 => "a required value word is missing",
        29 => "G59.x work coordinate systems are not supported",
        30 => "G53 only works with G0 or G1",
        31 => "axis words on a line where no command uses them",
        32 => "an arc (G2/G3) needs at least one axis word in the selected plane",
        33 => "the motion target is invalid (e.g. an arc that cannot be drawn)",
        34 => "the arc radius is invalid",
        35 => "an arc (G2/G3) needs at least one offset word in the selected plane",
        36 => "value words no command on the line uses",
        37 => "the tool length offset (G43.1) is not on the configured axis",
        38 => "the tool number is larger than supported",
        c => extended_error(c),
    }
}

/// What an `ALARM:N` means (Grbl 1.1, codes 1..9, shared by grblHAL and FluidNC; beyond them,
/// what each of those two means by it), in our words.
pub(crate) fn alarm_meaning(code: u8) -> &'static str {
    match code {
        1 => "hard limit: a limit switch was hit; position is lost, home the machine again",
        2 => "soft limit: a move would leave the machine's travel; position is kept",
        3 => "reset while moving: position may be lost, home or re-zero the machine",
        4 => "probe fail: the probe was not in its expected state before probing",
        5 => "probe fail: the probe did not make contact within the travel",
        6 => "homing fail: homing was reset",
        7 => "homing fail: the safety door opened during homing",
        8 => "homing fail: the pull-off move did not clear the limit switch",
        9 => "homing fail: no limit switch was found within the search distance",
        c => extended_alarm(c),
    }
}

/// Error codes beyond Grbl 1.1's, as grblHAL and FluidNC number them.
fn extended_error(code: u8) -> &'static str {
    match code {
        18 => "grblHAL: a reset was asserted; FluidNC: homing has no cycles configured",
        19 => "grblHAL: a value that must be above zero is not; FluidNC: single-axis homing is not allowed",
        39 => "grblHAL: a value is out of range; FluidNC: a P parameter exceeds its maximum",
        40 => "grblHAL: not allowed while a tool change is pending; FluidNC: a control or limit input is active at startup",
        41 => "grblHAL: the spindle is not running for a spindle-synchronized move",
        42 => "grblHAL: the plane must be ZX for threading",
        43 => "grblHAL: the maximum feed rate is exceeded",
        44 => "grblHAL: the spindle speed (S) is out of range",
        45 => "grblHAL: a limit switch is engaged: only homing is allowed",
        46 => "grblHAL: the machine must be homed first",
        47 => "grblHAL: the tool changer's current tool is not set (M61)",
        48 => "grblHAL: value words conflict",
        49 => "grblHAL: the power-on self test failed: a hard reset is needed",
        50 => "grblHAL: the emergency stop is active",
        51 => "grblHAL: a motor driver reports a fault",
        52 => "grblHAL: the setting's value is out of range",
        53 => "grblHAL: the setting is not available on this board",
        54 => "grblHAL: the retract position is below the drill depth",
        55 => "grblHAL: two auto-squared axes cannot home at once",
        56 => "grblHAL: the coordinate system is locked",
        57 => "grblHAL: an unexpected file demarcation (%)",
        58 => "grblHAL: the auxiliary port is not available",
        60 => "the SD card or file system failed to mount",
        61 => "a file could not be read",
        62 => "a directory could not be opened",
        63 => "the directory was not found",
        64 => "grblHAL: the SD card is not mounted; FluidNC: the file is empty",
        65 => "grblHAL: the file system is not mounted; FluidNC: the file was not found",
        66 => "grblHAL: the file system is read-only; FluidNC: the file could not be opened",
        67 => "FluidNC: the file system is busy",
        68 => "FluidNC: the directory could not be deleted",
        69 => "FluidNC: the file could not be deleted",
        70 => "grblHAL: Bluetooth failed to start; FluidNC: the file could not be renamed",
        71..=76 => "grblHAL: an expression could not be evaluated",
        77 => "grblHAL: authentication is required",
        78 => "grblHAL: access denied",
        79 => "grblHAL: not allowed while a critical event is active",
        80 => "grblHAL: a flow statement outside a macro; FluidNC: a setting number out of range",
        81 => "grblHAL: an unknown flow statement; FluidNC: an invalid setting value",
        82 => "grblHAL: flow control stack overflow; FluidNC: a file could not be created",
        83 => "grblHAL: flow control out of memory; FluidNC: the file system could not be formatted",
        84 => "grblHAL: a file could not be opened",
        85 => "grblHAL: the file system could not be formatted",
        86 => "grblHAL: the auxiliary port is not usable",
        87 => "grblHAL: a tool is in the spindle",
        88 => "grblHAL: no tool is in the spindle",
        89 => "grblHAL: a file could not be deleted",
        90 => "grblHAL: cutter compensation is already active; FluidNC: a message could not be sent",
        91 => "grblHAL: not allowed while cutter compensation is active",
        92 => "grblHAL: cutter compensation is not valid for this move",
        100 => "FluidNC: a setting could not be stored",
        101 => "FluidNC: the settings storage could not be read",
        110 => "FluidNC: authentication failed",
        111 => "FluidNC: end of line",
        112 => "FluidNC: end of file",
        113 => "FluidNC: reset",
        114 => "FluidNC: no data",
        120 => "FluidNC: another interface is busy (a job runs from the card or another link)",
        130 => "FluidNC: the jog was cancelled",
        150 => "FluidNC: a bad pin in the configuration file",
        151 => "FluidNC: a bad runtime configuration setting",
        152 => "FluidNC: the configuration file is invalid",
        160 => "FluidNC: the upload failed",
        161 => "FluidNC: the download failed",
        162 => "FluidNC: the setting is read-only (it comes from the configuration file)",
        170..=175 => "FluidNC: an expression could not be evaluated",
        176..=179 => "FluidNC: a flow control statement failed",
        180 => "FluidNC: a parameter could not be assigned",
        181 => "FluidNC: a G-code value word is invalid",
        253 => "grblHAL: an error a plugin defined",
        _ => "an error code this program does not know (newer firmware?)",
    }
}

/// Alarm codes beyond Grbl 1.1's, as grblHAL and FluidNC number them.
fn extended_alarm(code: u8) -> &'static str {
    match code {
        10 => "grblHAL: the emergency stop was pressed; FluidNC: the spindle control failed",
        11 => {
            "grblHAL: homing is required; FluidNC: a control or limit input was active at startup"
        }
        12 => {
            "grblHAL: a limit switch was engaged at startup; FluidNC: a homing switch is ambiguous"
        }
        13 => "grblHAL: the probe is protected (triggered during a move); FluidNC: a hard stop",
        14 => "grblHAL: the spindle is at the wrong speed; FluidNC: the machine is not homed",
        15 => "grblHAL: auto-squaring found no switch; FluidNC: the board failed to start",
        16 => "grblHAL: the power-on self test failed; FluidNC: an I/O expander reset",
        17 => "grblHAL: a motor driver reports a fault; FluidNC: a G-code error stopped the job",
        18 => "grblHAL: homing failed; FluidNC: the probe hit a hard limit",
        19 => "grblHAL: a Modbus exception",
        20 => "grblHAL: an I/O expander exception",
        21 => "grblHAL: the settings storage failed",
        22 => "grblHAL: a buffer overflowed",
        _ => "an alarm code this program does not know (newer firmware?)",
    }
}
