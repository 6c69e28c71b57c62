//! The work done answering rays, for summaries and benchmarks.

/// Work done answering rays, for the summary line and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Rays answered.
    pub rays: u64,
    /// Point evaluations of f (and g).
    pub f_evals: u64,
    /// Interval evaluations of f (over a piece, or at a point whose sign
    /// the f64 value could not certify).
    pub interval_evals: u64,
    /// Leaves visited.
    pub leaves: u64,
    /// Rays answered with a hit.
    pub hits: u64,
    /// Rays answered with a touch.
    pub touches: u64,
    /// Rays answered undecided.
    pub undecided: u64,
    /// Pieces of split leaves answered in closed form (see
    /// [`Tracer::set_closed_form_seams`](crate::ray::Tracer::set_closed_form_seams)).
    pub seams: u64,
    /// Rays that searched a bundle's leaf list instead of walking the
    /// octree ([`Tracer::first_hit_in`](crate::ray::Tracer::first_hit_in)).
    pub listed: u64,
    /// Rays answered in closed form: the formula is affine over the box
    /// (see [`Tracer::set_closed_form_planes`](crate::ray::Tracer::set_closed_form_planes)).
    pub closed_form: u64,
    /// Pieces of rays inside a cell of their leaf where f's enclosure
    /// excludes 0 (see [`Cells`](crate::ray::octree::Cells)): no
    /// evaluation needed.
    pub clear_cells: u64,
    /// Interval evaluations over the region a bundle's rays cross in a
    /// leaf, shared by their pieces there.
    pub shared_evals: u64,
    /// Pieces whose enclosures were their bundle's shared ones.
    pub shared_pieces: u64,
}

impl RayStats {
    /// The work done since `earlier`, a snapshot of the same tally.
    pub fn since(&self, earlier: &RayStats) -> RayStats {
        RayStats {
            rays: self.rays - earlier.rays,
            f_evals: self.f_evals - earlier.f_evals,
            interval_evals: self.interval_evals - earlier.interval_evals,
            leaves: self.leaves - earlier.leaves,
            hits: self.hits - earlier.hits,
            touches: self.touches - earlier.touches,
            undecided: self.undecided - earlier.undecided,
            seams: self.seams - earlier.seams,
            listed: self.listed - earlier.listed,
            closed_form: self.closed_form - earlier.closed_form,
            clear_cells: self.clear_cells - earlier.clear_cells,
            shared_evals: self.shared_evals - earlier.shared_evals,
            shared_pieces: self.shared_pieces - earlier.shared_pieces,
        }
    }

    /// Adds another tally to this one.
    pub fn add(&mut self, other: &RayStats) {
        self.rays += other.rays;
        self.f_evals += other.f_evals;
        self.interval_evals += other.interval_evals;
        self.leaves += other.leaves;
        self.hits += other.hits;
        self.touches += other.touches;
        self.undecided += other.undecided;
        self.seams += other.seams;
        self.listed += other.listed;
        self.closed_form += other.closed_form;
        self.clear_cells += other.clear_cells;
        self.shared_evals += other.shared_evals;
        self.shared_pieces += other.shared_pieces;
    }
}
