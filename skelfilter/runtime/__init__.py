"""What a run needs from the process: progress, signal shielding, memory checks, child processes
and the optional extras. The lowest layer: it imports nothing else of skelfilter but the errors."""
