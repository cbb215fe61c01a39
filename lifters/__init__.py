"""Shipped lifters (installed as package sparseedm.lifters); see README.md here."""
