//! Live mode: the composition root on a pseudo-terminal (and optionally a
//! TCP socket), ticking at 1 kHz paced by the wall clock, so the unchanged
//! ROS 2 driver or the configurator can connect to the printed device path.
//! Linux only (uses `openpty`).

use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use firmware::root::HostConfig;
use kernel::config::Validated;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};

use crate::plant::PlantOptions;
use crate::root::{Root, SimPort};

/// Live-mode options.
#[derive(Clone, Debug)]
pub struct LiveOptions {
    /// Also listen on this TCP address (`127.0.0.1:PORT`), one client at a time.
    pub tcp: Option<String>,
    /// Simulated milliseconds per wall-clock millisecond (1 = real time).
    /// Clients must scale their own rates by the same factor.
    pub speed: f64,
    /// Stop after this many wall-clock seconds (default: run until killed).
    pub run_for: Option<f64>,
    /// The main loop's settings (feedback lines and their rates).
    pub host: HostConfig,
    /// The simulated arm.
    pub plant: PlantOptions,
}

impl LiveOptions {
    /// Defaults: real time, the USB build's main loop (both clients), the
    /// default plant.
    pub fn new(cfg: &Validated) -> Self {
        LiveOptions {
            tcp: None,
            speed: 1.0,
            run_for: None,
            host: HostConfig::USB,
            plant: PlantOptions::new(cfg.config()),
        }
    }
}

fn set_nonblocking<F: AsRawFd>(fd: &F) -> Result<()> {
    let flags = fcntl(fd.as_raw_fd(), FcntlArg::F_GETFL).context("fcntl(F_GETFL)")?;
    let flags = OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK;
    fcntl(fd.as_raw_fd(), FcntlArg::F_SETFL(flags)).context("fcntl(F_SETFL, O_NONBLOCK)")?;
    Ok(())
}

struct Outputs {
    master: File,
    tcp: Option<TcpListener>,
    client: Option<TcpStream>,
}

impl Outputs {
    fn read_into(&mut self, buf: &mut Vec<u8>) -> Result<()> {
        let mut tmp = [0u8; 4096];
        loop {
            match self.master.read(&mut tmp) {
                Ok(0) => break,
                Ok(n) => buf.extend_from_slice(&tmp[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::Interrupted => break,
                // EIO: no process has the slave open (we keep it open, so rare).
                Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => break,
                Err(e) => return Err(e).context("reading the pseudo-terminal"),
            }
        }
        if let Some(l) = &self.tcp {
            match l.accept() {
                Ok((s, peer)) => {
                    s.set_nonblocking(true).context("setting the TCP client non-blocking")?;
                    let _ = s.set_nodelay(true);
                    println!("tcp client connected from {peer}");
                    self.client = Some(s);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                Err(e) => eprintln!("tcp accept failed: {e}"),
            }
        }
        let mut drop_client = false;
        if let Some(c) = &mut self.client {
            loop {
                match c.read(&mut tmp) {
                    Ok(0) => {
                        drop_client = true;
                        break;
                    }
                    Ok(n) => buf.extend_from_slice(&tmp[..n]),
                    Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::Interrupted => break,
                    Err(_) => {
                        drop_client = true;
                        break;
                    }
                }
            }
        }
        if drop_client {
            println!("tcp client disconnected");
            self.client = None;
        }
        Ok(())
    }

    /// The port's transmit side: the connected TCP client if there is one,
    /// else the pseudo-terminal. Never blocks; returns how many bytes the
    /// transport took (what it did not take stays in the firmware's transmit
    /// ring, where the shared root counts and reports any loss).
    fn write(&mut self, b: &[u8]) -> usize {
        if let Some(c) = &mut self.client {
            return match c.write(b) {
                Ok(n) => n,
                Err(e) if e.kind() == ErrorKind::WouldBlock || e.kind() == ErrorKind::Interrupted => 0,
                Err(_) => {
                    println!("tcp client disconnected");
                    self.client = None;
                    0
                }
            };
        }
        // WouldBlock: nobody is reading and the pty buffer is full.
        self.master.write(b).unwrap_or_default()
    }
}

/// Runs live mode until killed (or `run_for` elapses).
pub fn run_live(cfg: &Validated, o: &LiveOptions) -> Result<()> {
    let pty = nix::pty::openpty(None, None).context("opening a pseudo-terminal (openpty)")?;
    let mut t = tcgetattr(&pty.slave).context("reading the pty's terminal settings")?;
    cfmakeraw(&mut t);
    tcsetattr(&pty.slave, SetArg::TCSANOW, &t).context("setting the pty to raw mode")?;
    let path = nix::unistd::ttyname(&pty.slave).context("finding the pty's device path")?;
    set_nonblocking(&pty.master)?;
    let tcp = match &o.tcp {
        Some(a) => {
            let l = TcpListener::bind(a).with_context(|| format!("listening on {a}"))?;
            l.set_nonblocking(true).context("setting the TCP listener non-blocking")?;
            Some(l)
        }
        None => None,
    };
    let io = Arc::new(Mutex::new(Outputs { master: File::from(pty.master), tcp, client: None }));
    // Keep the slave side open so the master never sees EIO between clients.
    let _slave = pty.slave;
    println!("PTY {}", path.display());
    if let Some(a) = &o.tcp {
        println!("TCP {a}");
    }
    println!(
        "simulated PAROL6 running at {}x real time; connect the ROS 2 driver or the configurator to {} \
         (115200 8N1, any baud works on a pty). Ctrl-C stops.",
        o.speed,
        path.display()
    );

    let sink_io = Arc::clone(&io);
    let port = SimPort::with_sink(Box::new(move |b: &[u8]| sink_io.lock().map_or(0, |mut o| o.write(b))));
    let mut root = Root::with_port(cfg, o.plant.clone(), o.host, port);
    let start = Instant::now();
    let mut t_sim: u64 = 0;
    let mut pending: Vec<u8> = Vec::new();
    let mut checker = crate::runner::TickChecker::new(cfg);
    let mut violations = 0u64;
    let mut last_state = None;
    let mut skipped = 0u64;
    loop {
        let wall = start.elapsed().as_secs_f64();
        if o.run_for.is_some_and(|d| wall >= d) {
            break;
        }
        io.lock().map_err(|_| anyhow::anyhow!("pty state poisoned"))?.read_into(&mut pending)?;
        let due = (wall * 1000.0 * o.speed) as u64;
        let due = due.saturating_sub(skipped);
        if due > t_sim + 1000 {
            // More than a second behind (process suspended?): do not replay it.
            skipped += due - t_sim - 1000;
            continue;
        }
        while t_sim < due {
            let input = std::mem::take(&mut pending);
            let step = root.step(&input);
            for l in &step.lines {
                if !l.trim_start().starts_with('<') {
                    print!("{:>9.3} s  {l}", t_sim as f64 / 1000.0);
                }
            }
            let st = step.out.status.state;
            if last_state != Some(st) {
                println!("{:>9.3} s  state {st:?}", t_sim as f64 / 1000.0);
                last_state = Some(st);
            }
            for v in checker.check(&step) {
                violations += 1;
                eprintln!("{:>9.3} s  SAFETY VIOLATION: {v}", t_sim as f64 / 1000.0);
            }
            t_sim += 1;
        }
        std::thread::sleep(Duration::from_micros(250));
    }
    let tx = root.tx_counters();
    println!(
        "stopped after {:.1} s simulated; {} lines sent, {} dropped (slow or absent reader; reported on the wire as \
         TX_LOST), {} critical dropped; {} ms skipped; {} safety violations",
        t_sim as f64 / 1000.0,
        tx.queued,
        tx.dropped + tx.dropped_closed,
        tx.critical_dropped,
        skipped,
        violations
    );
    Ok(())
}
