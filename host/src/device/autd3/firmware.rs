//! The firmware an AUTD3 rig must run: the autd3 crates lmhost is built
//! with (38) speak firmware v12.1, and another version misreads their
//! frames, so [`check`] refuses a rig that runs anything else when it
//! opens, naming what it found and what is needed.

use autd3_driver::firmware::version::FirmwareVersion;

/// The firmware version these autd3 crates speak, as autd3 names it.
pub fn needed() -> String {
    // v12.1.x: autd3 maps the major byte to "v12.1", the minor to the patch.
    let v = FirmwareVersion::latest();
    v.rsplit_once('.')
        .map_or(v.clone(), |(mm, _)| mm.to_string())
}

/// Refuses `versions` (one per device, as autd3 reads them) unless every
/// device's CPU and FPGA firmware has the major version these crates
/// speak; the error is one line: the first device that differs, its
/// versions, and the one needed.
pub fn check(versions: &[FirmwareVersion]) -> Result<(), String> {
    let want = FirmwareVersion::LATEST_VERSION_NUM_MAJOR;
    match versions
        .iter()
        .find(|v| v.cpu.major != want || v.fpga.major != want)
    {
        None => Ok(()),
        Some(v) => Err(format!(
            "AUTD3 device {} runs firmware CPU {}, FPGA {}; this lmhost (autd3 38) needs {}: \
             update the firmware (autd3's firmware writer) or use an lmhost built for it",
            v.idx,
            v.cpu,
            v.fpga,
            needed()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use autd3_driver::firmware::version::{CPUVersion, FPGAVersion, Major, Minor};

    fn version(idx: usize, cpu: u8, fpga: u8) -> FirmwareVersion {
        FirmwareVersion {
            idx,
            cpu: CPUVersion {
                major: Major(cpu),
                minor: Minor(0),
            },
            fpga: FPGAVersion {
                major: Major(fpga),
                minor: Minor(0),
                function_bits: 0,
            },
        }
    }

    #[test]
    fn only_the_version_autd3_38_speaks_passes() {
        assert_eq!(needed(), "v12.1");
        let ok = version(0, 0xA5, 0xA5);
        assert_eq!(check(&[ok, version(1, 0xA5, 0xA5)]), Ok(()));
        // v12.0 on the CPU of device 2, v11.0 on the FPGA of device 1.
        let e = check(&[ok, ok, version(2, 0xA4, 0xA5)]).unwrap_err();
        assert!(
            e.contains("device 2 runs firmware CPU v12.0.0, FPGA v12.1.0"),
            "{e}"
        );
        assert!(e.contains("needs v12.1"), "{e}");
        assert!(!e.contains('\n'));
        let e = check(&[version(1, 0xA5, 0xA3)]).unwrap_err();
        assert!(e.contains("FPGA v11.0.0"), "{e}");
        // Newer than these crates know is refused too.
        assert!(check(&[version(0, 0xA6, 0xA6)]).is_err());
    }
}
