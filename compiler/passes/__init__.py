"""eomc.compiler.passes"""
