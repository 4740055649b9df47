"""Running the pipeline on a cluster: a one-node SLURM cluster for trying the profile."""
