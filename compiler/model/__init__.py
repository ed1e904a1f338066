"""eomc.compiler.model"""
