"""Scoring a submission: writing and validating submissions (`submission`, `validate`), scoring
them into results (`score`, `results`), bootstrap intervals (`intervals`) and the machine part
of a result's provenance (`provenance`)."""
