//! Proof files: every corpus surface's L (and G on a ray) proved, written,
//! read back and re-checked by the independent checker; every alteration
//! that makes a proof wrong is rejected.

use crate::common::{corpus, lgc_with_stdin, Rng};
use glam::DVec3;
use lgc::bounds::{bracket_grad_lipschitz, bracket_lipschitz, prove, refute};
use lgc::proof::{check, Claim, Entry, Outcome, Proof, Rejection};
use lgc::{Aabb, Bounder, Formula, Segment};

fn lipschitz_claim(constant: f64, lo: [f64; 3], hi: [f64; 3]) -> Claim {
    Claim::Lipschitz {
        constant: format!("{constant:?}"),
        region: [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]],
    }
}

#[test]
fn every_corpus_surface_has_proofs_of_l_and_g_that_check() {
    let mut rng = Rng::new(48);
    let surfaces = corpus();
    let mut rays_proved = 0;
    for s in &surfaces {
        let f = Formula::parse(&s.expr).unwrap();
        let bounder = Bounder::new(&f);
        let b = Aabb::new(DVec3::from(s.lo), DVec3::from(s.hi)).unwrap();
        let l = bracket_lipschitz(&bounder, &b, 0.01, 100_000).upper * 1.02;
        let proof = prove(&s.expr, lipschitz_claim(l, s.lo, s.hi), 1_000_000).unwrap();
        // Written and read back exactly, it still checks.
        let back = Proof::from_json(&proof.to_json()).unwrap();
        assert_eq!(back, proof, "{}", s.name);
        let checked = check(&back).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        assert!(checked.proved && checked.largest <= l, "{}", s.name);
        // The claim is true where it can be sampled.
        for _ in 0..200 {
            let p = [0, 1, 2].map(|k| rng.uniform(s.lo[k], s.hi[k]));
            let g = bounder.gradient_norm_at_least(DVec3::from(p));
            assert!(g <= l, "{}: |grad f| >= {g} > {l} at {p:?}", s.name);
        }

        // G on a ray through the box's centre.
        let c = b.center();
        let d = DVec3::from(rng.direction());
        let half = 0.5 * b.diagonal() / d.length();
        let seg = Segment::new(c - half * d, d, 0.0, 2.0 * half).unwrap();
        let g = bracket_grad_lipschitz(&bounder, &seg, 0.01, 100_000).upper * 1.02;
        if !g.is_finite() {
            // A kink near the ray (min, abs): lgc's bracket gives up on an
            // unbounded piece, so there is no constant to prove.
            continue;
        }
        let claim = Claim::GradLipschitz {
            constant: format!("{g:?}"),
            ray: [seg.origin.x, seg.origin.y, seg.origin.z, d.x, d.y, d.z],
            t: [seg.t0, seg.t1],
        };
        let proof = prove(&s.expr, claim, 1_000_000).unwrap();
        let checked = check(&Proof::from_json(&proof.to_json()).unwrap())
            .unwrap_or_else(|e| panic!("{} along a ray: {e}", s.name));
        assert!(checked.proved, "{}", s.name);
        rays_proved += 1;
    }
    eprintln!("G proved on {rays_proved} of {} rays", surfaces.len());
    assert!(
        rays_proved + 2 >= surfaces.len(),
        "G proved on {rays_proved} rays"
    );
}

fn tree(proof: &Proof) -> &Vec<Entry> {
    match &proof.outcome {
        Outcome::Proved(entries) => entries,
        Outcome::Refuted { .. } => panic!("a proof of a true claim"),
    }
}

fn with_tree(proof: &Proof, entries: Vec<Entry>) -> Proof {
    Proof {
        outcome: Outcome::Proved(entries),
        ..proof.clone()
    }
}

/// A proof of two balls' exponential smooth union's L ≤ 1.5 over [0.1, 1]³
/// took 240,159 leaves when the checker differentiated `ln` of the sum of
/// exponentials as a quotient of them; by the documented weighted mean it
/// takes under a thousand, and checks.
#[test]
fn a_smooth_union_proof_differentiates_ln_of_exps_as_a_mean() {
    let union = "-ln(exp(-16*(sqrt(x^2+y^2+z^2)-0.8)) + exp(-16*(sqrt((x-0.7)^2+y^2+z^2)-0.5)))/16";
    let proof = prove(union, lipschitz_claim(1.5, [0.1; 3], [1.0; 3]), 100_000).unwrap();
    let checked = check(&Proof::from_json(&proof.to_json()).unwrap()).unwrap();
    assert!(checked.proved && checked.largest <= 1.5);
    assert!(checked.leaves < 2_000, "{} leaves", checked.leaves);
}

#[test]
fn every_alteration_that_makes_a_proof_wrong_is_rejected() {
    let tangle = "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8";
    let proof = prove(tangle, lipschitz_claim(140.0, [-3.0; 3], [3.0; 3]), 100_000).unwrap();
    let entries = tree(&proof).clone();
    assert!(check(&proof).is_ok());
    assert!(entries.len() > 50, "a tree worth tampering with");
    for (k, e) in entries.iter().enumerate() {
        let mut altered = entries.clone();
        match *e {
            // A leaf's bound one ulp lower than its natural extension shows.
            Entry::Leaf(b) => {
                altered[k] = Entry::Leaf(b.next_down());
                let r = check(&with_tree(&proof, altered.clone()));
                assert!(
                    matches!(r, Err(Rejection::LeafBound { entry, .. }) if entry == k),
                    "leaf {k}: {r:?}"
                );
                // Above the constant.
                altered[k] = Entry::Leaf(140f64.next_up());
                let r = check(&with_tree(&proof, altered));
                assert!(
                    matches!(r, Err(Rejection::AboveClaim { .. })),
                    "leaf {k}: {r:?}"
                );
            }
            // A split moved by one ulp either way, or onto another axis.
            Entry::Split { axis, at } => {
                for moved in [at.next_up(), at.next_down()] {
                    altered[k] = Entry::Split { axis, at: moved };
                    let r = check(&with_tree(&proof, altered.clone()));
                    assert!(
                        matches!(r, Err(Rejection::BadSplit { entry, .. }) if entry == k),
                        "split {k}: {r:?}"
                    );
                }
                altered[k] = Entry::Split { axis: 3, at };
                assert!(
                    check(&with_tree(&proof, altered)).is_err(),
                    "split {k} on axis 3"
                );
            }
        }
    }
    // Leaves missing, or left over.
    let r = check(&with_tree(&proof, entries[..entries.len() - 1].to_vec()));
    assert!(matches!(r, Err(Rejection::Tiling(_))), "{r:?}");
    let mut longer = entries.clone();
    longer.push(Entry::Leaf(1.0));
    assert!(matches!(
        check(&with_tree(&proof, longer)),
        Err(Rejection::Tiling(_))
    ));
    // The constant lowered below the largest leaf.
    let largest = check(&proof).unwrap().largest;
    let lowered = Proof {
        claim: lipschitz_claim(largest.next_down(), [-3.0; 3], [3.0; 3]),
        ..proof.clone()
    };
    assert!(matches!(check(&lowered), Err(Rejection::AboveClaim { .. })));
    // The formula's leading coefficient raised by one ulp: its slope grows
    // past the largest leaf's recorded bound.
    let steeper = Proof {
        formula: tangle.replacen("x^4", "1.0000000000000002*x^4", 1),
        ..proof.clone()
    };
    assert!(
        matches!(check(&steeper), Err(Rejection::LeafBound { .. })),
        "{:?}",
        check(&steeper)
    );
}

#[test]
fn a_refutation_checks_and_a_stretched_one_is_rejected() {
    let claim = lipschitz_claim(6.0, [-1.0; 3], [1.0; 3]);
    let proof = refute("x^4+y^4+z^4-1", claim.clone(), [1.0, -1.0, 1.0], None).unwrap();
    let checked = check(&Proof::from_json(&proof.to_json()).unwrap()).unwrap();
    assert!(!checked.proved && checked.largest > 6.0);
    let Outcome::Refuted {
        point, at_least, ..
    } = proof.outcome
    else {
        panic!("a refutation");
    };
    let alter = |point: [f64; 3], at_least: f64| Proof {
        outcome: Outcome::Refuted {
            point,
            t: None,
            at_least,
        },
        ..proof.clone()
    };
    // The value one ulp above what the checker certifies.
    assert!(matches!(
        check(&alter(point, at_least.next_up())),
        Err(Rejection::Witness(_))
    ));
    // The witness one ulp outside the box.
    assert!(matches!(
        check(&alter([1f64.next_up(), -1.0, 1.0], at_least)),
        Err(Rejection::Witness(_))
    ));
    // A constant at the certified value.
    let higher = Proof {
        claim: lipschitz_claim(at_least, [-1.0; 3], [1.0; 3]),
        ..proof.clone()
    };
    assert!(matches!(check(&higher), Err(Rejection::Witness(_))));
    // A witness where the claim holds is no refutation.
    assert!(refute("x^4+y^4+z^4-1", claim, [0.1, 0.1, 0.1], None).is_err());
}

fn lgc(args: &[&str]) -> std::process::Output {
    lgc_with_stdin(args, "")
}

#[test]
fn verify_writes_proofs_that_check_proof_accepts_and_a_tampered_one_it_rejects() {
    let dir = std::env::temp_dir().join(format!("lgc-proof-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("goursat.json");
    let path = file.to_str().unwrap();
    let f = "x^4+y^4+z^4-(x^2+y^2+z^2)";
    let out = lgc(&[
        "verify",
        f,
        "--box=-1.5,-1.5,-1.5,1.5,1.5,1.5",
        "--lipschitz",
        "19",
        "--proof",
        path,
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = lgc(&["check-proof", path]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.starts_with("valid: proves max |grad f| <= 19"),
        "{text}"
    );
    // Every leaf bound written with the shortest digits that read back:
    // one lowered in its last digit is rejected, in one line.
    let json = std::fs::read_to_string(&file).unwrap();
    let proof = Proof::from_json(&json).unwrap();
    let last_leaf = tree(&proof)
        .iter()
        .rposition(|e| matches!(e, Entry::Leaf(_)))
        .unwrap();
    let mut entries = tree(&proof).clone();
    let Entry::Leaf(b) = entries[last_leaf] else {
        unreachable!()
    };
    entries[last_leaf] = Entry::Leaf(b.next_down());
    std::fs::write(&file, with_tree(&proof, entries).to_json()).unwrap();
    let out = lgc(&["check-proof", path]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.starts_with("error: rejected: tree entry") && err.lines().count() == 1,
        "{err}"
    );

    // A refutation; then no proof for an undecided claim (the constant is
    // the true maximum, at the corners), and none written.
    let refuted = dir.join("refuted.json");
    let out = lgc(&[
        "verify",
        f,
        "--box=-1.5,-1.5,-1.5,1.5,1.5,1.5",
        "--lipschitz",
        "10",
        "--proof",
        refuted.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(3));
    let out = lgc(&["check-proof", refuted.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (v["valid"].as_bool(), v["verdict"].as_str()),
        (Some(true), Some("refuted"))
    );
    let none = dir.join("undecided.json");
    let out = lgc(&[
        "verify",
        f,
        "--box=-1.5,-1.5,-1.5,1.5,1.5,1.5",
        "--lipschitz",
        "10.5*sqrt(3)",
        "--max-boxes",
        "1000",
        "--proof",
        none.to_str().unwrap(),
    ]);
    assert_ne!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no proof written"));
    assert!(!none.exists());
    // A function outside the checker's language is shown with a caret.
    let out = lgc(&[
        "verify",
        "translate(x^2+y^2+z^2-1, 0.1, 0, 0)",
        "--box=-1,-1,-1,1,1,1",
        "--lipschitz",
        "5",
        "--proof",
        none.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("^^^^^^^^^") && err.contains("translate"),
        "{err}"
    );
    assert!(!none.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
