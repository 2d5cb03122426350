use kernel::config::PAROL6;
use kernel::{KernelF32, Request, State};
use sim::encoder::DecodeMode;
use sim::plant::{Plant, PlantOptions};
fn main() {
    for mode in [DecodeMode::Frame, DecodeMode::Window] {
        let mut o = PlantOptions::new(&PAROL6);
        o.decode = mode;
        let mut p = Plant::new(&PAROL6, o);
        let (mut k, _a) = KernelF32::new(&PAROL6);
        let mut t = 0;
        let mut homed_at = None;
        while t < 40000 {
            let s = p.sense();
            let req = if t == 100 { Some(Request::Home) } else { None };
            let out = k.tick(&s, req);
            for e in out.events.iter() {
                println!("{mode:?} t={t} {e:?}");
            }
            p.apply(&out.act.step_rate);
            if out.status.state == State::Operational && homed_at.is_none() {
                homed_at = Some(t);
                let q = p.q();
                println!("homed at {t}: est {:?} true {:?}", out.status.position, q);
                break;
            }
            if out.status.state == State::Fault {
                break;
            }
            t += 1;
        }
        println!("{mode:?}: {:?}", p.decode_stats());
    }
}
