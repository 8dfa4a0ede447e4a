"""Ankle and hip balance strategies with smooth transitions (Nenchev & Nishio, ICRA 2010) as FMI 2.0 co-simulation FMUs."""
__version__ = "0.1.0"
