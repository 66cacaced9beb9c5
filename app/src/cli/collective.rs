//! `meta-train`'s data-parallel flag: how the processes of a run talk (docs/neural.md,
//! *Several machines*). The launcher (`mpirun`, Slurm's `srun`) starts the processes and MPI
//! tells each its rank; nothing is read from the environment here.

use avatar_neural::training::collective::{Collective, Transport};

#[derive(clap::Args, Debug)]
pub struct CollectiveArgs {
    /// none (one process) or mpi (every process the MPI launcher started takes its share of
    /// each iteration's tasks; a build with the `mpi` feature).
    #[arg(long, default_value = "none")]
    collective: String,
}

impl CollectiveArgs {
    /// Checked before anything is read or written.
    pub fn transport(&self) -> anyhow::Result<Transport> {
        Ok(Transport::parse(&self.collective)?)
    }

    /// Join the run the launcher started.
    pub fn join(&self) -> anyhow::Result<Collective> {
        let collective = Collective::join(self.transport()?)?;
        if collective.world() > 1 {
            eprintln!("meta-train: rank {} of {}", collective.rank(), collective.world());
        }
        Ok(collective)
    }
}

/// A rank that failed ends every rank of the run, after saying why (the others would wait in
/// the next all-reduce, and finalizing MPI would wait for them).
pub fn or_abort<T>(collective: &Collective, result: avatar_neural::Result<T>) -> anyhow::Result<T> {
    match result {
        Err(e) if collective.world() > 1 => {
            eprintln!("error: rank {}: {e}", collective.rank());
            collective.abort_run(1);
            Err(e.into())
        }
        r => Ok(r?),
    }
}
