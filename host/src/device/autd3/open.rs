//! Opening an AUTD3 rig: the port's link, the scene checked against the
//! rig, the firmware version checked against what these autd3 crates
//! speak, and the devices left muted with the firmware's defaults.

use std::time::Duration;

use anyhow::{Context, bail};
use autd3::Controller;
use autd3::core::link::Link;
use autd3::prelude::{ParallelMode, ReadsFPGAState, SenderOption, Silencer};
use lm_fw_core::player::Player;

use super::device::Autd3Backend;
use super::emulator::{EmulatorHandle, EmulatorLink};
use super::output::Output;
use super::port::Autd3Port;
use super::{correction, firmware, geometry, safety};
use crate::clock::Clock;
use crate::device::backend::DEFAULT_LEASE;
use crate::error::InputError;
use crate::plan::scene::Scene;

/// The emulator answers at once, so frames go back to back; real links keep
/// autd3's pacing (one frame per 1 ms, ack polled every 1 ms).
fn sender_option(emulated: bool) -> SenderOption {
    if emulated {
        SenderOption {
            send_interval: None,
            receive_interval: None,
            timeout: Some(Duration::from_millis(200)),
            parallel: ParallelMode::Off,
        }
    } else {
        SenderOption::default()
    }
}

impl Autd3Backend {
    /// Opens `port` for `scene`. The emulator gets as many devices as the
    /// scene; a real link must report the same number.
    pub fn open(port: &Autd3Port, scene: &Scene) -> anyhow::Result<Self> {
        match port {
            Autd3Port::Emulator => Ok(Self::open_emulator(scene, Clock::real(), None)?.0),
            Autd3Port::EmulatorRig { devices } => {
                Ok(Self::open_emulator(scene, Clock::real(), Some(*devices))?.0)
            }
            Autd3Port::Remote { host, port: tcp } => {
                use std::net::ToSocketAddrs;
                let addr = (host.as_str(), *tcp)
                    .to_socket_addrs()
                    .with_context(|| format!("resolving {port}"))?
                    .next()
                    .with_context(|| format!("{port}: the host has no address"))?;
                let link = autd3_link_remote::Remote::new(
                    addr,
                    autd3_link_remote::RemoteOption {
                        timeout: Some(Duration::from_secs(2)),
                    },
                );
                Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
            }
            #[cfg(feature = "autd3-soem")]
            Autd3Port::Soem { ifname } => {
                super::ethercat::preflight(&port.to_string(), ifname.as_deref())?;
                let link = autd3_link_soem::SOEM::new(
                    |slave: u16, status: autd3_link_soem::Status| {
                        crate::errln!("lmhost: AUTD3 device {slave}: EtherCAT {status:?}");
                    },
                    autd3_link_soem::SOEMOption {
                        ifname: ifname.clone(),
                        ..Default::default()
                    },
                );
                Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
            }
            #[cfg(feature = "autd3-ethercrab")]
            Autd3Port::EtherCrab { ifname } => {
                super::ethercat::preflight(&port.to_string(), ifname.as_deref())?;
                let open = |ifname: &str| {
                    let link = autd3_link_ethercrab::EtherCrab::new(
                        |dev: usize, status: autd3_link_ethercrab::Status| {
                            crate::errln!("lmhost: AUTD3 device {dev}: EtherCAT {status:?}");
                        },
                        autd3_link_ethercrab::EtherCrabOption {
                            ifname: Some(ifname.to_string()),
                            ..Default::default()
                        },
                    );
                    Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
                };
                match ifname {
                    Some(i) => open(i),
                    // ethercrab's own search walks libpcap's device list,
                    // whose pseudo-devices (names of 16+ bytes such as
                    // `bluetooth-monitor`) panic it: walk the kernel's
                    // network interfaces instead, first answer wins.
                    None => {
                        let tried =
                            super::ethercat::candidates(std::path::Path::new("/sys/class/net"));
                        for i in &tried {
                            if let Ok(me) = open(i) {
                                return Ok(me);
                            }
                        }
                        bail!(
                            "opening {port}: no AUTD3 device answered on any interface (tried {})",
                            if tried.is_empty() {
                                "none".to_string()
                            } else {
                                tried.join(", ")
                            }
                        )
                    }
                }
            }
            #[allow(unreachable_patterns)]
            other => bail!(
                "{other}: this lmhost was built without the `{}` feature (EtherCAT links are opt-in: they need system libraries and raw-socket privileges)",
                other.feature().unwrap_or("?")
            ),
        }
    }

    /// Opens an emulated rig of `rig_devices` boards (`None`: the scene's
    /// count) on `clock`, returning the handle to its emulated devices.
    pub fn open_emulator(
        scene: &Scene,
        clock: Clock,
        rig_devices: Option<usize>,
    ) -> anyhow::Result<(Self, EmulatorHandle)> {
        if let Some(n) = rig_devices.filter(|&n| n != scene.devices.len()) {
            return Err(InputError::new(format!(
                "scene `{}` has {} devices but the AUTD3 rig has {n}",
                scene.name,
                scene.devices.len()
            ))
            .into());
        }
        let (link, handle) = EmulatorLink::new(clock.clone());
        let me = Self::open_link(
            Box::new(link),
            Autd3Port::Emulator,
            scene,
            clock,
            Some(handle.clone()),
        )?;
        Ok((me, handle))
    }

    /// Opens `link` (already built for `port`) for `scene`.
    pub fn open_link(
        link: Box<dyn Link>,
        port: Autd3Port,
        scene: &Scene,
        clock: Clock,
        emulator: Option<EmulatorHandle>,
    ) -> anyhow::Result<Self> {
        geometry::check_no_overlap(scene)?;
        let positions = correction::packed_positions_um(scene)?;
        let mut ctl = Controller::open_with(
            geometry::devices(scene),
            link,
            sender_option(emulator.is_some()),
            autd3::core::sleep::StdSleeper,
        )
        .map_err(|e| {
            if emulator.is_none() && port.feature().is_some() {
                // EtherCAT: the link's bare "timeout" made specific.
                anyhow::anyhow!(super::ethercat::explain(&format!("opening {port}"), &e))
            } else {
                anyhow::Error::new(e).context(format!("opening {port}"))
            }
        })?;
        let versions = ctl
            .firmware_version()
            .with_context(|| format!("{port}: reading the firmware versions"))?;
        firmware::check(&versions).map_err(|e| anyhow::anyhow!("{port}: {e}"))?;
        // autd3 lengths are mm, so its sound speed is mm/s.
        ctl.environment.sound_speed = scene.sound_speed_m_s as f32 * 1000.0;
        geometry::check_positions(scene, ctl.geometry())?;
        let n = ctl.num_transducers();
        let opened_us = clock.now_us();
        let mut me = Self {
            ctl,
            port,
            emulator,
            clock,
            opened_us,
            positions,
            slots: [None; 2],
            stm_segment: None,
            player: Player::new(super::device::TIMER_HZ),
            policy: safety::policy(),
            output: Output::new(DEFAULT_LEASE)?,
            offsets: vec![0; n],
            offsets_for: None,
            late_steps: 0,
            closed: false,
        };
        me.ctl.send(Silencer::default())?;
        me.ctl.send(ReadsFPGAState::new(|_| true))?;
        me.output.mute(&mut me.ctl)?;
        me.send_offsets()?;
        Ok(me)
    }
}
