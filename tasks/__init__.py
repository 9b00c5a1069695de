"""dm_control tasks of the dcmppi benchmark."""
