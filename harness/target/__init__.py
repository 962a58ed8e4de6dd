"""The target stage: cross-builds and resource budgets, processor-in-the-loop runs under QEMU,
MISRA checks, and A2L addresses from linked firmware."""
