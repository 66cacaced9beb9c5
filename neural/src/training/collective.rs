//! Data-parallel collectives for meta-training over several processes and machines, on MPI
//! (the `mpi` crate over the system's MPI library, in builds with the `mpi` feature): the
//! launcher (`mpirun`, Slurm's `srun`) starts one process per node and tells each its rank;
//! MPI's all-reduce sums the ranks' vectors. No networking of our own: this module only hands
//! flat `f32` vectors to `MPI_Allreduce`.
//!
//! One `Collective` per process (MPI is initialised once). A run of one process
//! (`Transport::Single`) never touches MPI. The caller (the CLI) chooses the transport; nothing
//! here reads the environment (MPI's own library reads what its launcher set).

use crate::error::{Error, Result};

/// How the processes of a run talk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transport {
    /// One process: every reduction is the identity.
    Single,
    /// The processes an MPI launcher started (`mpirun`, `srun --mpi=pmix`); rank and world size
    /// come from MPI. Needs a build with the `mpi` feature.
    Mpi,
}

impl Transport {
    pub fn parse(name: &str) -> Result<Transport> {
        match name {
            "single" | "none" => Ok(Transport::Single),
            "mpi" => Ok(Transport::Mpi),
            other => Err(Error::invalid(format!("unknown collective {other:?}: none or mpi"))),
        }
    }
}

/// A process's membership of a data-parallel run: all-reduce (sum) of flat vectors.
pub struct Collective {
    rank: usize,
    world: usize,
    #[cfg(feature = "mpi")]
    mpi: Option<mpi::environment::Universe>,
}

impl Collective {
    /// A run of one process: every reduction is the identity, nothing is started.
    pub fn single() -> Collective {
        Collective {
            rank: 0,
            world: 1,
            #[cfg(feature = "mpi")]
            mpi: None,
        }
    }

    /// Join the run the launcher started (`Transport::Mpi`: initialises MPI; a process started
    /// without a launcher is a world of one).
    pub fn join(transport: Transport) -> Result<Collective> {
        match transport {
            Transport::Single => Ok(Collective::single()),
            Transport::Mpi => Collective::mpi(),
        }
    }

    #[cfg(feature = "mpi")]
    fn mpi() -> Result<Collective> {
        use mpi::traits::Communicator;
        let universe = mpi::initialize()
            .ok_or_else(|| Error::invalid("MPI is already initialised in this process"))?;
        let world = universe.world();
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        Ok(Collective { rank, world: size, mpi: Some(universe) })
    }

    #[cfg(not(feature = "mpi"))]
    fn mpi() -> Result<Collective> {
        Err(Error::invalid(
            "this build has no MPI: rebuild with `cargo build --release --features mpi` (needs libopenmpi-dev and libclang-dev)",
        ))
    }

    pub fn rank(&self) -> usize {
        self.rank
    }

    pub fn world(&self) -> usize {
        self.world
    }

    /// Whether this process writes the run's files (checkpoints, the loss log, the model).
    pub fn is_root(&self) -> bool {
        self.rank == 0
    }

    /// Replace `values` by their sum over every process. All processes must call it with
    /// vectors of the same length, in the same order of calls.
    pub fn all_reduce_sum(&self, values: &mut [f32]) -> Result<()> {
        if self.world == 1 || values.is_empty() {
            return Ok(());
        }
        self.mpi_all_reduce(values)
    }

    #[cfg(feature = "mpi")]
    fn mpi_all_reduce(&self, values: &mut [f32]) -> Result<()> {
        use mpi::collective::{CommunicatorCollectives, SystemOperation};
        let universe = self.mpi.as_ref().expect("a world above one is an MPI world");
        let send = values.to_vec();
        // MPI aborts the job on an error (its default handler): nothing to map here.
        universe.world().all_reduce_into(&send[..], values, SystemOperation::sum());
        Ok(())
    }

    #[cfg(not(feature = "mpi"))]
    fn mpi_all_reduce(&self, _values: &mut [f32]) -> Result<()> {
        unreachable!("a world above one exists only with MPI")
    }

    /// Whether any process says yes (e.g. a cancelled run stops on every rank at once).
    pub fn any(&self, flag: bool) -> Result<bool> {
        let mut v = [f32::from(u8::from(flag))];
        self.all_reduce_sum(&mut v)?;
        Ok(v[0] > 0.5)
    }

    /// End every process of the run with `code`: a rank that failed calls it, or the others would
    /// wait forever in the next all-reduce (the launcher then ends the job). One process:
    /// returns.
    pub fn abort_run(&self, code: i32) {
        #[cfg(feature = "mpi")]
        if let (true, Some(universe)) = (self.world > 1, &self.mpi) {
            use mpi::traits::Communicator;
            universe.world().abort(code);
        }
        let _ = code;
    }

    /// Wait until every process has called it.
    pub fn barrier(&self) -> Result<()> {
        self.any(false).map(|_| ())
    }
}

impl Drop for Collective {
    /// A rank that panics ends the run instead of leaving the others waiting (and instead of
    /// finalizing MPI, which waits for them).
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.abort_run(101);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_process_reduces_to_itself() {
        let c = Collective::join(Transport::Single).unwrap();
        let mut v = vec![1.5, -2.0];
        c.all_reduce_sum(&mut v).unwrap();
        assert_eq!(v, [1.5, -2.0]);
        assert!(c.any(true).unwrap() && !c.any(false).unwrap());
        assert!(c.is_root() && c.world() == 1 && c.rank() == 0);
    }

    #[test]
    fn transports_are_named() {
        assert_eq!(Transport::parse("mpi").unwrap(), Transport::Mpi);
        assert_eq!(Transport::parse("none").unwrap(), Transport::Single);
        let err = Transport::parse("nccl").unwrap_err().to_string();
        assert!(err.contains("none or mpi"), "{err}");
    }

    #[cfg(not(feature = "mpi"))]
    #[test]
    fn a_build_without_mpi_says_how_to_get_it() {
        let err = Collective::join(Transport::Mpi).err().unwrap().to_string();
        assert!(err.contains("--features mpi"), "{err}");
    }
}
