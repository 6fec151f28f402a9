"""Simulated plant factory: world, cameras, Modbus TCP motion controller and clock. The only package that knows it is a simulation."""
